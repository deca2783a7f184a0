"""Loaders by file extension: CSV, MATLAB .mat (v5 and v7.3), HDF5 and UFF dataset 58.

The same simulated two-DOF record is written in every format; each must load to the same
Signals as the CSV and give the same identification (coefficients equal to 1e-9 relative).
"""

from __future__ import annotations

import gc
import sys
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyuff
import scipy.io

from bayesnsi.exceptions import ConfigError, InputDataError
from bayesnsi.io import (
    dump_config,
    file_format,
    load_config,
    load_signals,
    load_validation,
    read_columns,
    read_signals,
    uff_channel_key,
    write_signals_csv,
)
from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.simulate import simulate_case

SILVERBOX = Path("/work/shared/data/silverbox/SNLS80mV.mat")
FS = 100.0


@pytest.fixture(scope="module")
def case():
    return simulate_case("two-dof", seed=0)


@pytest.fixture(scope="module")
def columns(case):
    s = case.signals
    return {
        "f2": s.force[:, 0], "x1": s.displacement[:, 0], "x2": s.displacement[:, 1],
        "v1": s.velocity[:, 0], "v2": s.velocity[:, 1],
    }


MAPPING = {"inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}, "velocities": {"v1": 1, "v2": 2}}
CANDIDATES = [{"name": "model 1", "terms": [{"expr": "v1*abs(v1)", "at": 1}]}]


def _config(folder: Path, file: str, name: str = "experiment.toml", **data) -> Path:
    section = {"file": file, **MAPPING, **data}
    section = {k: v for k, v in section.items() if v is not None}
    path = folder / name
    path.write_text(dump_config({"data": section, "candidates": CANDIDATES}))
    return path


def _load(folder: Path, file: str, **data):
    return load_signals(load_config(_config(folder, file, **data)))


# ---------------------------------------------------------------------------------------------
# writers of each format (as a lab's software would produce them)


def _write_mat5(path: Path, columns: dict, **extra) -> Path:
    variables = {}
    for k, (name, values) in enumerate(columns.items()):
        values = np.asarray(values, dtype=float)
        variables[name] = values[None, :] if k % 2 == 0 else values[:, None]  # 1×N and N×1 both occur
    variables.update(extra)
    scipy.io.savemat(path, variables)
    return path


def _write_mat73(path: Path, columns: dict, **extra) -> Path:
    """A MATLAB v7.3 file: HDF5 with a 512-byte user block holding the MAT header."""
    with h5py.File(path, "w", userblock_size=512) as h5:
        for name, values in {**columns, **extra}.items():
            row = np.atleast_2d(np.asarray(values, dtype=float))  # MATLAB 1×N ...
            h5.create_dataset(name, data=row.T)  # ... is stored transposed (column-major)
            h5[name].attrs["MATLAB_class"] = np.bytes_("double")
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(text.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM")
    return path


# record keys used in the UFF tests: forces and displacements by id1 text, velocities by node:dir
UFF_RECORDS = {
    "f2": dict(id1="f2", rsp_node=2, rsp_dir=3, ordinate_spec_data_type=13, ordinate_axis_units_lab="N"),
    "x1": dict(id1="x1", rsp_node=1, rsp_dir=3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m"),
    "x2": dict(id1="x2", rsp_node=2, rsp_dir=3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m"),
    "v1": dict(id1="velocity 1", rsp_node=101, rsp_dir=3, ordinate_spec_data_type=11, ordinate_axis_units_lab="m/s"),
    "v2": dict(id1="velocity 2", rsp_node=102, rsp_dir=-1, ordinate_spec_data_type=11, ordinate_axis_units_lab="m/s"),
}
UFF_MAPPING = {"inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}, "velocities": {"101:+Z": 1, "102:-X": 2}}


def _write_uff(path: Path, columns: dict, binary: int = 1, fs: float = FS, overrides: dict | None = None) -> Path:
    # pyuff 2.5's binary writer leaves file objects open: collect them here, warnings silenced
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        _write_uff_sets(path, columns, binary, fs, overrides or {})
        gc.collect()
    return path


def _write_uff_sets(path: Path, columns: dict, binary: int, fs: float, overrides: dict) -> None:
    uff = pyuff.UFF(str(path))
    for name, values in columns.items():
        fields = dict(
            binary=binary, func_type=1, ref_node=0, ref_dir=0, rsp_ent_name="bench", ref_ent_name="bench",
            abscissa_spacing=1, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
            orddenom_spec_data_type=0, z_axis_spec_data_type=0,
            **UFF_RECORDS[name],
        )
        fields.update(overrides.get(name, {}))
        x = np.arange(len(values)) / fields.pop("fs", fs) + fields.pop("t0", 0.0)
        uff.write_sets(pyuff.prepare_58(data=np.asarray(values, dtype=float), x=x, **fields), mode="add")


# ---------------------------------------------------------------------------------------------
# the same data in every format


def test_file_format_by_extension():
    assert [file_format(p) for p in ("a.csv", "b.MAT", "c.h5", "d.hdf5", "e.uff", "f.UNV", "g.txt")] == [
        "csv", "mat", "hdf5", "hdf5", "uff", "uff", "csv",
    ]


def test_every_format_loads_the_same_signals_and_identification(tmp_path, case, columns):
    write_signals_csv(tmp_path / "data.csv", case.signals, float_format="%.17g")
    _write_mat5(tmp_path / "data5.mat", columns)
    _write_mat73(tmp_path / "data73.mat", columns)
    _write_mat73(tmp_path / "data.h5", columns)
    _write_uff(tmp_path / "data.uff", columns)
    reference = _load(tmp_path, "data.csv", fs=FS)
    loaded = {
        "mat v5": _load(tmp_path, "data5.mat", fs=FS),
        "mat v7.3": _load(tmp_path, "data73.mat", fs=FS),
        "hdf5": _load(tmp_path, "data.h5", fs=FS),
        "uff58": load_signals(load_config(_write_uff_config(tmp_path, "data.uff"))),  # fs from abscissa_inc
    }
    for fmt, signals in loaded.items():
        for field in ("force", "displacement", "velocity"):
            np.testing.assert_array_equal(getattr(signals, field), getattr(reference, field), err_msg=fmt)
        assert (signals.fs, signals.input_dofs, signals.output_dofs) == (FS, (2,), (1, 2)), fmt
    np.testing.assert_array_equal(reference.displacement, case.signals.displacement)

    expected = identify(reference, case.candidates[0], NSIOptions(block_rows=60, order=4))
    assert expected.coefficient_values[0] == pytest.approx(20.0, rel=0.1)
    for fmt, signals in loaded.items():
        result = identify(signals, case.candidates[0], NSIOptions(block_rows=60, order=4))
        np.testing.assert_allclose(result.coefficient_values, expected.coefficient_values, rtol=1e-9, err_msg=fmt)
        np.testing.assert_allclose(
            [m.frequency_hz for m in result.modes], [m.frequency_hz for m in expected.modes], rtol=1e-9, err_msg=fmt
        )


def _write_uff_config(folder: Path, file: str, name: str = "uff.toml", **data) -> Path:
    section = {"file": file, **UFF_MAPPING, **data}
    path = folder / name
    path.write_text(dump_config({"data": section, "candidates": CANDIDATES}))
    return path


def test_uff_ascii_units_keys_and_uneven_abscissa(tmp_path, columns):
    _write_uff(tmp_path / "ascii.uff", columns, binary=0)
    signals = load_signals(load_config(_write_uff_config(tmp_path, "ascii.uff", fs=FS)))
    # ASCII UFF58 keeps 12 significant digits (E20.12)
    x2 = columns["x2"]
    np.testing.assert_allclose(signals.displacement[:, 1], x2, rtol=1e-10, atol=1e-11 * np.abs(x2).max())
    table = read_columns(tmp_path / "ascii.uff", ["x1", "101:Z", "velocity 2", "102:-1"])
    assert table.fs == pytest.approx(FS, rel=1e-12) and table.format == "uff"
    assert table.units == {"x1": "m", "101:Z": "m/s", "velocity 2": "m/s", "102:-1": "m/s"}
    np.testing.assert_array_equal(table.values["velocity 2"], table.values["102:-1"])
    assert uff_channel_key({"rsp_node": 102, "rsp_dir": -1}) == "102:-X"
    assert "'velocity 1' (101:+Z)" in table.names

    uneven = {name: dict(abscissa_spacing=0) for name in columns}
    _write_uff(tmp_path / "uneven.uff", columns, binary=0, overrides=uneven)
    back = load_signals(load_config(_write_uff_config(tmp_path, "uneven.uff", name="u.toml")))
    assert back.fs == pytest.approx(FS, rel=1e-6)
    np.testing.assert_allclose(back.force[:, 0], columns["f2"], rtol=1e-10, atol=1e-10 * np.abs(columns["f2"]).max())


def test_mat_time_vector_and_fs_variable(tmp_path, columns):
    n = len(columns["f2"])
    _write_mat5(tmp_path / "t.mat", columns, t=np.arange(n) / 250.0)
    assert _load(tmp_path, "t.mat").fs == pytest.approx(250.0, rel=1e-12)
    _write_mat5(tmp_path / "fs.mat", columns, fs=250.0)
    assert _load(tmp_path, "fs.mat").fs == 250.0
    assert _load(tmp_path, "fs.mat", fs=250.0 * (1 + 1e-6)).fs == 250.0 * (1 + 1e-6)  # config wins if it agrees
    _write_mat73(tmp_path / "fs73.mat", columns, fs=[250.0])
    assert _load(tmp_path, "fs73.mat").fs == 250.0


def test_estimation_window_validation_and_mean_removal_in_mat(tmp_path, case, columns):
    write_signals_csv(tmp_path / "data.csv", case.signals, float_format="%.17g")
    _write_mat5(tmp_path / "data.mat", columns)
    configs = {}
    for file in ("data.csv", "data.mat"):
        path = tmp_path / f"{file}.toml"
        raw = {
            "data": {"file": file, "fs": FS, **MAPPING, "estimation": [0, 800], "remove_mean": True},
            "candidates": CANDIDATES, "validation": [{"name": "tail", "start": 800, "stop": 1000}],
        }
        path.write_text(dump_config(raw))
        configs[file] = load_config(path)
    est = {f: load_signals(c) for f, c in configs.items()}
    val = {f: load_validation(c) for f, c in configs.items()}
    np.testing.assert_array_equal(est["data.csv"].displacement, est["data.mat"].displacement)
    np.testing.assert_array_equal(val["data.csv"][0][1].velocity, val["data.mat"][0][1].velocity)
    assert est["data.mat"].n_samples == 800 and val["data.mat"][0][1].n_samples == 200


# ---------------------------------------------------------------------------------------------
# errors


def test_mat_errors(tmp_path, columns):
    n = len(columns["f2"])
    without_x2 = {k: v for k, v in columns.items() if k != "x2"}
    _write_mat5(tmp_path / "missing.mat", without_x2)
    with pytest.raises(InputDataError, match=r"variable\(s\) \['x2'\] not found; available: .*'x1'"):
        _load(tmp_path, "missing.mat", fs=FS)

    _write_mat5(tmp_path / "short.mat", {**columns, "x2": columns["x2"][:-5]})
    with pytest.raises(InputDataError, match=r"different lengths .*'x2': 995"):
        _load(tmp_path, "short.mat", fs=FS)

    scipy.io.savemat(tmp_path / "matrix.mat", {**columns, "x1": np.column_stack([columns["x1"], columns["x2"]])})
    with pytest.raises(InputDataError, match=r"'x1' has shape \(1000, 2\); expected a vector"):
        _load(tmp_path, "matrix.mat", fs=FS)

    scipy.io.savemat(tmp_path / "struct.mat", {**columns, "x1": {"values": columns["x1"]}})
    with pytest.raises(InputDataError, match="'x1' is a MATLAB struct, not a real numeric vector"):
        _load(tmp_path, "struct.mat", fs=FS)

    scipy.io.savemat(tmp_path / "complex.mat", {**columns, "x1": columns["x1"] * (1 + 1j)})
    with pytest.raises(InputDataError, match="'x1' .*not a real numeric vector"):
        _load(tmp_path, "complex.mat", fs=FS)

    _write_mat5(tmp_path / "nofs.mat", columns)
    with pytest.raises(InputDataError, match="no sampling frequency .*no time variable 't' and no scalar variable"):
        _load(tmp_path, "nofs.mat")

    _write_mat5(tmp_path / "fs200.mat", columns, fs=200.0)
    with pytest.raises(InputDataError, match=r"variable 'fs' gives fs = 200 Hz but \[data\] fs = 100 Hz"):
        _load(tmp_path, "fs200.mat", fs=FS)

    _write_mat5(tmp_path / "t200.mat", columns, t=np.arange(n) / 200.0)
    with pytest.raises(InputDataError, match=r"time variable 't' gives fs = 200 Hz but \[data\] fs = 100 Hz"):
        _load(tmp_path, "t200.mat", fs=FS)

    jitter = np.arange(n) / FS
    jitter[7] += 0.3 / FS
    _write_mat5(tmp_path / "jitter.mat", columns, t=jitter)
    with pytest.raises(InputDataError, match="not uniformly sampled.*at sample 7"):
        _load(tmp_path, "jitter.mat")

    nan = columns["x1"].copy()
    nan[42] = np.nan
    _write_mat5(tmp_path / "nan.mat", {**columns, "x1": nan})
    with pytest.raises(InputDataError, match=r"'x1' has 1 missing .* the first at sample 42;"):
        _load(tmp_path, "nan.mat", fs=FS)

    (tmp_path / "text.mat").write_text("not a mat file\n")
    with pytest.raises(InputDataError, match="cannot read it as a MATLAB .mat file"):
        _load(tmp_path, "text.mat", fs=FS)


def test_hdf5_errors(tmp_path, columns):
    path = _write_mat73(tmp_path / "group.mat", columns)
    with h5py.File(path, "a") as h5:
        del h5["x1"]
        h5.create_group("x1").create_dataset("values", data=columns["x1"])
        h5.create_dataset("v1c", data=np.array([b"abc"]))
        h5["v1c"].attrs["MATLAB_class"] = np.bytes_("char")
    with pytest.raises(InputDataError, match="'x1' is a group"):
        _load(tmp_path, "group.mat", fs=FS)
    with pytest.raises(InputDataError, match="'v1c' is a MATLAB char"):
        read_columns(path, ["v1c"])
    with pytest.raises(InputDataError, match=r"\['nope'\] not found; available: .*'f2'"):
        read_columns(path, ["nope"])
    (tmp_path / "fake.h5").write_bytes(b"plain bytes")
    with pytest.raises(InputDataError, match="not an HDF5 file"):
        read_columns(tmp_path / "fake.h5", ["x1"])
    _write_mat73(tmp_path / "short.h5", {**columns, "v2": columns["v2"][:10]})
    with pytest.raises(InputDataError, match="different lengths"):
        _load(tmp_path, "short.h5", fs=FS)


@pytest.mark.parametrize("module, extra, file", [("h5py", "hdf5", "data.h5"), ("pyuff", "uff", "data.uff")])
def test_missing_optional_reader_names_the_extra(tmp_path, monkeypatch, module, extra, file):
    path = tmp_path / file
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(64))  # an HDF5 signature; any bytes for UFF
    monkeypatch.setitem(sys.modules, module, None)  # as if the extra were not installed
    with pytest.raises(InputDataError) as info:
        read_columns(path, ["x1"])
    message = str(info.value)
    assert f"pip install 'bayesnsi[{extra}]'" in message and "\n" not in message


def test_uff_errors(tmp_path, columns):
    _write_uff(tmp_path / "ok.uff", columns)
    with pytest.raises(InputDataError, match=r"no record 'x3'; .*'x1' \(1:\+Z\)"):
        read_columns(tmp_path / "ok.uff", ["x3"])
    with pytest.raises(InputDataError, match=r"fs = 100 Hz but \[data\] fs = 200 Hz"):
        load_signals(load_config(_write_uff_config(tmp_path, "ok.uff", fs=200.0)))

    _write_uff(tmp_path / "rates.uff", columns, overrides={"v1": {"fs": 200.0}})
    with pytest.raises(InputDataError, match="inconsistent sampling intervals between records"):
        load_signals(load_config(_write_uff_config(tmp_path, "rates.uff")))

    _write_uff(tmp_path / "shifted.uff", columns, overrides={"x2": {"t0": 0.5}})
    with pytest.raises(InputDataError, match="records start at different times"):
        load_signals(load_config(_write_uff_config(tmp_path, "shifted.uff")))

    _write_uff(tmp_path / "short.uff", {**columns, "x2": columns["x2"][:900]})
    with pytest.raises(InputDataError, match="different lengths"):
        load_signals(load_config(_write_uff_config(tmp_path, "short.uff")))

    _write_uff(tmp_path / "twins.uff", columns, overrides={"x2": {"id1": "x1"}})
    with pytest.raises(InputDataError, match="'x1' matches 2 records by id1"):
        read_columns(tmp_path / "twins.uff", ["x1"])
    with pytest.raises(InputDataError, match=r"'2:\+Z' matches 2 records by response node and direction"):
        read_columns(tmp_path / "ok.uff", ["2:+Z"])  # the force f2 and the displacement x2

    _write_uff(tmp_path / "frf.uff", columns, overrides={"x1": {"func_type": 4}})
    with pytest.raises(InputDataError, match=r"function type 4 \(frequency response function\)"):
        read_columns(tmp_path / "frf.uff", ["x1"])

    _write_uff(tmp_path / "accel.uff", columns, overrides={"x1": {"ordinate_spec_data_type": 12}})
    with pytest.raises(InputDataError, match="holds acceleration .* maps it as displacement"):
        load_signals(load_config(_write_uff_config(tmp_path, "accel.uff")))

    _write_uff(tmp_path / "mm.uff", columns, overrides={"x2": {"ordinate_axis_units_lab": "mm"}})
    with pytest.raises(InputDataError, match=r"displacement channels are in different units .*'x2': 'mm'"):
        load_signals(load_config(_write_uff_config(tmp_path, "mm.uff")))

    (tmp_path / "empty.uff").write_text("    -1\n   151\nheader only\n    -1\n")
    with pytest.raises(InputDataError, match="no dataset 58"):
        read_columns(tmp_path / "empty.uff", ["x1"])


def test_missing_file_is_reported(tmp_path):
    config = _config(tmp_path, "gone.mat", fs=FS)
    with pytest.raises(ConfigError, match="not found"):
        load_config(config)
    with pytest.raises(InputDataError, match="not found"):
        read_signals(tmp_path / "gone.mat", load_config(config, check_files=False).data)


# ---------------------------------------------------------------------------------------------
# real data


@pytest.mark.skipif(not SILVERBOX.is_file(), reason="Silverbox data not available")
def test_silverbox_mat(tmp_path):
    raw = {
        "data": {"file": str(SILVERBOX), "fs": 610.3515625, "inputs": {"V1": 1}, "outputs": {"V2": 1}},
        "candidates": [{"name": "cubic", "terms": [{"expr": "x1**3", "at": 1}]}],
    }
    path = tmp_path / "silverbox.toml"
    path.write_text(dump_config(raw))
    signals = load_signals(load_config(path))
    assert signals.n_samples == 131072 and signals.fs == 610.3515625
    reference = scipy.io.loadmat(SILVERBOX)
    np.testing.assert_array_equal(signals.force[:, 0], reference["V1"].ravel())
    np.testing.assert_array_equal(signals.displacement[:, 0], reference["V2"].ravel())
    assert signals.input_names == ("V1",) and signals.output_names == ("V2",)
