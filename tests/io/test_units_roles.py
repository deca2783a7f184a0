"""A file's units row against the role [data] gives each column, and validation files against the estimation file.

Velocity columns (m/s) mapped as accelerations would be integrated twice without a word (exit 0, the true
model unstable); acceleration columns (m/s^2) mapped as outputs would be identified as displacements; a
validation file in g beside an estimation file in m/s^2 would give a validation error of 0.90 and no
message. Each is an InputDataError that names the column, its unit and the fix.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import InputDataError, IntegrationWarning
from bayesnsi.io import load_config, load_signals, load_validation
from bayesnsi.io._record import quantity_of_unit


@pytest.mark.parametrize("unit, quantity", [
    ("m/s^2", "acceleration"), ("m/s²", "acceleration"), ("mm/s**2", "acceleration"), ("m/s2", "acceleration"),
    ("m/s", "velocity"), ("mm / s", "velocity"), ("in/s", "velocity"),
    ("m", "displacement"), ("µm", "displacement"), ("mm", "displacement"),
    ("m s^-2", "acceleration"), ("m/s/s", "acceleration"), ("m s^-1", "velocity"),
    ("g", "acceleration"), ("V", None), ("N", None), ("", None), ("m/s^3", None),
])
def test_quantity_of_unit_names_only_unambiguous_units(unit, quantity):
    assert quantity_of_unit(unit) == quantity


def _write(path, units, scale=1.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(400) / 100.0
    f = rng.standard_normal(400)
    y = np.cumsum(rng.standard_normal((400, 2)), axis=0) * 1e-3 * scale
    rows = "\n".join(",".join(f"{v:.8e}" for v in row) for row in np.column_stack([t, f, y]))
    path.write_text("t,f,c1,c2\n" + units + "\n" + rows + "\n")


def _config(tmp_path, data_lines, validation=""):
    text = ('[data]\nfile = "est.csv"\ninputs = { f = 1 }\n' + data_lines + validation
            + '[nsi]\nblock_rows = 4\norder = 2\n[[candidates]]\nname = "linear"\nterms = []\n')
    (tmp_path / "c.toml").write_text(text)
    return load_config(tmp_path / "c.toml")


def test_a_unit_that_names_another_quantity_than_the_role_is_refused(tmp_path):
    _write(tmp_path / "est.csv", "s,N,m/s,m/s")
    with pytest.raises(InputDataError, match=r"'c1' is in 'm/s', a velocity, .* under accelerations .* map it under "
                                             r"velocities with integrate"):
        load_signals(_config(tmp_path, "accelerations = { c1 = 1, c2 = 2 }\nintegrate = { band_hz = [1, 40] }\n"))
    _write(tmp_path / "est.csv", "s,N,m/s^2,m/s^2")
    with pytest.raises(InputDataError, match=r"'c1' is in 'm/s\^2', an? acceleration, .* under outputs"):
        load_signals(_config(tmp_path, "outputs = { c1 = 1, c2 = 2 }\n"))
    # the right role loads; so does a wrong units row corrected by [data] units
    _write(tmp_path / "est.csv", "s,N,m,m")
    assert load_signals(_config(tmp_path, "outputs = { c1 = 1, c2 = 2 }\n")).measured == "displacement"
    _write(tmp_path / "est.csv", "s,N,m/s,m/s")
    corrected = 'outputs = { c1 = 1, c2 = 2 }\nunits = { c1 = "m", c2 = "m" }\n'
    assert load_signals(_config(tmp_path, corrected)).displacement.shape == (400, 2)


def test_a_validation_file_in_other_units_is_refused(tmp_path):
    _write(tmp_path / "est.csv", "s,N,m,m")
    _write(tmp_path / "val.csv", "s,N,mm,mm", scale=1e3, seed=1)
    validation = '[[validation]]\nname = "other"\nfile = "val.csv"\n'
    config = _config(tmp_path, "outputs = { c1 = 1, c2 = 2 }\n", validation)
    with pytest.raises(InputDataError, match=r"val.csv states 'mm' for column 'c1' where the estimation file est.csv "
                                             r"states 'm'"):
        load_validation(config)
    _write(tmp_path / "val.csv", "s,N,m,m", seed=1)
    assert [name for name, _ in load_validation(config)] == ["other"]
    # the same unit spelled another way is the same unit; a [data] units label converts nothing, so the
    # files' own rows are still compared (g-valued columns labelled "g", validated on m/s^2)
    _write(tmp_path / "est.csv", "s,N,m/s^2,m/s^2")
    _write(tmp_path / "val.csv", "s,N,m s^-2,m/s2", seed=1)
    accelerations = "accelerations = { c1 = 1, c2 = 2 }\nintegrate = { band_hz = [1, 40] }\n"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)  # random walks: the motion lies below the band
        assert len(load_validation(_config(tmp_path, accelerations, validation))) == 1
        _write(tmp_path / "val.csv", "s,N,g,g", seed=1)
        labelled = accelerations + 'units = { c1 = "g", c2 = "g" }\n'
        with pytest.raises(InputDataError, match="states 'g' for column 'c1'"):
            load_validation(_config(tmp_path, labelled, validation))
