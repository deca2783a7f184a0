"""``[data] files``: one channel per file, as benchmark data are shipped (a Bouc-Wen-like record).

nonlinearbenchmark.org ships e.g. ``uval_multisine.csv`` and ``yval_multisine.csv``: input and output
apart, one headerless column of numbers each. Before ``files``, such data could only be read after
joining them by hand into one file with a header. The reference is the same data written as one
CSV with a header (the format ``[data] file`` always read): both must load to identical signals.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from bayesnsi.exceptions import ConfigError, InputDataError
from bayesnsi.io import load_config, load_signals, load_validation

N = 600
CONFIG = """
[data]
{source}
fs = 750.0
inputs = {{ u = 1 }}
outputs = {{ y = 1 }}
estimation = [0, 400]

[nsi]
block_rows = 10
order = 2

[[candidates]]
name = "linear"
terms = []

[[validation]]
name = "held out"
{validation}
"""


def _write(folder, name, values, header=None):
    path = folder / name
    lines = ([header] if header else []) + [",".join(f"{v:.12e}" for v in np.atleast_1d(row)) for row in values]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def record(tmp_path):
    """u, y (estimation) and u2, y2 (validation): random numbers are enough to test the reading."""
    rng = np.random.default_rng(0)
    u, y, u2, y2 = (rng.standard_normal(N) for _ in range(4))
    for name, values in (("u.csv", u), ("y.csv", y), ("uval.csv", u2), ("yval.csv", y2)):
        _write(tmp_path, name, values)
    _write(tmp_path, "joined.csv", np.c_[u, y], header="u,y")
    _write(tmp_path, "joined_val.csv", np.c_[u2, y2], header="u,y")
    return tmp_path, (u, y, u2, y2)


def _config(folder, source, validation, name="c.toml"):
    path = folder / name
    path.write_text(CONFIG.format(source=source, validation=validation))
    return path


def test_separate_headerless_files_load_as_the_joined_file(record):
    folder, (u, y, u2, y2) = record
    split = load_config(_config(folder, 'files = { u = "u.csv", y = "y.csv" }',
                                'files = { u = "uval.csv", y = "yval.csv" }'))
    joined = load_config(_config(folder, 'file = "joined.csv"', 'file = "joined_val.csv"', "j.toml"))
    a, b = load_signals(split), load_signals(joined)
    np.testing.assert_array_equal(a.force, b.force)
    np.testing.assert_array_equal(a.displacement, b.displacement)
    np.testing.assert_allclose(a.force[:, 0], u[:400], rtol=1e-11)
    np.testing.assert_allclose(a.displacement[:, 0], y[:400], rtol=1e-11)
    (name, va), = load_validation(split)
    (_, vb), = load_validation(joined)
    assert name == "held out"
    np.testing.assert_array_equal(va.displacement, vb.displacement)
    np.testing.assert_allclose(va.force[:, 0], u2, rtol=1e-11)


def test_validation_inside_the_split_record_and_per_channel_formats(record):
    folder, (u, y, _, _) = record
    _write(folder, "y_headed.csv", np.c_[y, -y], header="y,minus_y")  # a file with a header: the named column
    scipy.io.savemat(folder / "u.mat", {"u": u[:, None]})  # a MAT variable named as the channel
    config = load_config(_config(folder, 'files = { u = "u.mat", y = "y_headed.csv" }', "start = 450\nstop = 600"))
    signals = load_signals(config)
    np.testing.assert_allclose(signals.force[:, 0], u[:400], rtol=1e-12)
    np.testing.assert_allclose(signals.displacement[:, 0], y[:400], rtol=1e-11)
    (_, held), = load_validation(config)
    np.testing.assert_allclose(held.displacement[:, 0], y[450:600], rtol=1e-11)


@pytest.mark.parametrize(
    "source, validation, fragment",
    [
        ('files = { u = "u.csv" }', 'file = "joined_val.csv"', r"no file for column\(s\) \['y'\]"),
        ('files = { u = "u.csv", y = "y.csv", z = "y.csv" }', 'file = "joined_val.csv"', "have a file but no role"),
        ('file = "joined.csv"\nfiles = { u = "u.csv", y = "y.csv" }', 'file = "joined_val.csv"', "not both"),
        ('files = { u = "u.csv", y = "missing.csv" }', 'file = "joined_val.csv"', "not found"),
        ('files = { u = "u.csv", y = "y.csv" }', 'files = { u = "uval.csv" }', r"#1 files: no file for column"),
        ('files = "u.csv"', 'file = "joined_val.csv"', "a non-empty table mapping each column to its file"),
    ],
)
def test_config_mistakes_are_one_line_config_errors(record, source, validation, fragment):
    folder, _ = record
    with pytest.raises(ConfigError, match=fragment):
        load_config(_config(folder, source, validation))


def test_fs_is_required_with_files(record):
    folder, _ = record
    path = _config(folder, 'files = { u = "u.csv", y = "y.csv" }', 'file = "joined_val.csv"')
    path.write_text(path.read_text().replace("fs = 750.0\n", ""))
    with pytest.raises(ConfigError, match="fs: expected the sampling frequency in Hz.*carry no time column"):
        load_config(path)


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("1.0,2.0\n3.0,4.0\n", r"line 1: 2 cells; a headerless file of \[data\] files holds one channel"),
        ("1.0\n2.0\nabc\n4.0\n", r"line 3: channel 'y' expected a finite number"),
        ("1.0\n\n3.0\n", r"line 2: empty line inside channel 'y'"),
        ("1.0\nnan\n", r"line 2: channel 'y' expected a finite number"),
    ],
)
def test_bad_channel_files_name_the_file_and_line(record, content, fragment):
    folder, _ = record
    (folder / "y.csv").write_text(content)
    config = load_config(_config(folder, 'files = { u = "u.csv", y = "y.csv" }', 'file = "joined_val.csv"'))
    with pytest.raises(InputDataError, match=fragment) as raised:
        load_signals(config)
    assert "y.csv" in str(raised.value) and "abc" not in str(raised.value)  # names the file, quotes nothing


def test_files_of_different_lengths_are_refused(record):
    folder, (_, y, _, _) = record
    _write(folder, "y.csv", y[:500])
    config = load_config(_config(folder, 'files = { u = "u.csv", y = "y.csv" }', 'file = "joined_val.csv"'))
    with pytest.raises(InputDataError, match=r"samples \('u' \(u.csv\): 600, 'y' \(y.csv\): 500\)"):
        load_signals(config)


def test_a_benchmark_mat_file_of_one_variable_gives_that_channel(record):
    # nonlinearbenchmark.org's uval_multisine.mat holds one variable named after the file, not after the
    # config's column: with one vector in the file, that vector is the channel.
    folder, (u, y, _, _) = record
    scipy.io.savemat(folder / "uval_multisine.mat", {"uval_multisine": u[:, None], "fs": 750.0})
    config = load_config(_config(folder, 'files = { u = "uval_multisine.mat", y = "y.csv" }',
                                 'file = "joined_val.csv"'))
    np.testing.assert_allclose(load_signals(config).force[:, 0], u[:400], rtol=1e-15)
    scipy.io.savemat(folder / "two.mat", {"a": u[:, None], "b": y[:, None]})  # two vectors: which one? say so
    config = load_config(_config(folder, 'files = { u = "two.mat", y = "y.csv" }', 'file = "joined_val.csv"'))
    with pytest.raises(InputDataError, match=r"variable\(s\) \['u'\] not found; available: 'a', 'b'"):
        load_signals(config)


def test_a_data_table_without_file_names_both_ways_to_give_the_data(record):
    folder, _ = record
    path = _config(folder, "", 'file = "joined_val.csv"')
    with pytest.raises(ConfigError, match=r'\[data\] file: expected the measurement file, .*files = \{ u = "u.csv"'):
        load_config(path)


def test_a_missing_value_in_a_headed_channel_file_names_that_file_and_line(record):
    folder, _ = record
    (folder / "y.csv").write_text("y\n1.0\n\n3.0\n".replace("\n\n", "\n,\n"))  # line 3: an empty cell
    config = load_config(_config(folder, 'files = { u = "u.csv", y = "y.csv" }', 'file = "joined_val.csv"'))
    with pytest.raises(InputDataError, match=r"y.csv \(line 3\): channel 'y' expected a finite number"):
        load_signals(config)


def test_a_system_file_given_as_a_channel_file_is_refused_without_quoting_it(record, tmp_path):
    folder, _ = record
    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n")
    config = load_config(_config(folder, f'files = {{ u = "u.csv", y = "{secret}" }}', 'file = "joined_val.csv"'))
    with pytest.raises(InputDataError, match="a header without the column 'y'") as raised:
        load_signals(config)
    message = str(raised.value).replace(str(secret), "")
    assert "root" not in message and "daemon" not in message and "bash" not in message
