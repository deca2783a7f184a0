"""A measured ground vibration test (the F-16 benchmark, ../shared/data/f16) on slices of its records.

Skipped when the data are absent. The configs are those of ``workflows/f16``; the records are cut
to a few periods so that each test takes seconds. References computed here, independently of the
package's identification: the best linear approximation (period-averaged force and acceleration
spectra, numpy FFT) and its prediction of another level.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest

from bayesnsi.checks.validation import validate
from bayesnsi.exceptions import SpuriousPoleWarning
from bayesnsi.io import load_config, load_signals, load_validation
from bayesnsi.loop.localise import location_distortion
from bayesnsi.models import CandidateModel
from bayesnsi.nsi import identify

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "f16"
CONFIG = ROOT / "workflows" / "f16" / "level5.toml"
P = 8192
pytestmark = pytest.mark.skipif(not (DATA / "F16Data_FullMSine_Level5.csv").exists(),
                                reason="F-16 data not present beside the repository")


def _config(periods: int = 4, validation=("full multisine level 3",), stop_periods: int = 3):
    """level5.toml cut to ``periods`` steady periods, with the named validation segments cut to ``stop_periods``."""
    config = load_config(CONFIG)
    segments = []
    for segment in config.validation:
        if segment.name in validation:
            length = (segment.period or P) * stop_periods
            segments.append(dataclasses.replace(segment, stop=segment.start + length))
    data = dataclasses.replace(config.data, estimation=(P, P * (1 + periods)))
    return dataclasses.replace(config, data=data, validation=tuple(segments))


def _raw(name: str) -> np.ndarray:
    return np.genfromtxt(DATA / name, delimiter=",", skip_header=1, usecols=(0, 2, 3, 4))


def test_the_wing_payload_pair_leads_the_localisation():
    """On three periods of level 5 the relative motion of sensors 2 (wing) and 3 (payload), across the
    interface, is the most distorted location by far (the README's interface; 82x on the whole record)."""
    signals = load_signals(_config(periods=3))
    levels = location_distortion(signals, [(1,), (2,), (3,), (1, 2), (1, 3), (2, 3)])
    others = [level for loc, (level, _) in levels.items() if loc != (2, 3)]
    assert levels[(2, 3)][0] > 10 * max(others)


def test_the_linear_part_predicts_another_level_as_well_as_the_measured_frf():
    """Automatic order on four periods of level 5: the stable modes include the known ones (first
    flexible near 5.2 Hz at low level, wing torsion near 7.3 Hz; both lower at level 5), and the model
    predicts level 3 within 1.2x the error of level 5's own BLA applied to level 3's force."""
    config = _config(periods=4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # non-physical poles of the linear part, discarded
        signals, segments = load_signals(config), load_validation(config)
        result = identify(signals, CandidateModel("linear", ()), config.nsi)
    stable = np.array(result.fit.stable_modes_hz)
    for known in (5.1, 7.2, 9.1):
        assert np.min(np.abs(stable / known - 1)) < 0.02
    (found,) = validate(result, segments)
    # the reference: the BLA of the same four periods of level 5, applied to three periods of level 3
    est, val = _raw("F16Data_FullMSine_Level5.csv")[P : 5 * P], _raw("F16Data_FullMSine_Level3.csv")[P : 4 * P]
    spec = [np.fft.rfft(x.reshape(-1, P, 4), axis=1).mean(axis=0) for x in (est, val)]
    freqs = np.fft.rfftfreq(P, 1.0 / 400.0)
    lines = (freqs >= 2.0) & (freqs <= 15.0)
    frf = spec[0][lines, 1:] / spec[0][lines, :1]
    error = spec[1][lines, 1:] - frf * spec[1][lines, :1]
    per_sensor = np.sqrt(np.sum(np.abs(error) ** 2, axis=0) / np.sum(np.abs(spec[1][lines, 1:]) ** 2, axis=0))
    bla = float(np.sqrt(np.mean(per_sensor**2)))
    assert found.quantity == "acceleration" and found.error is None
    assert found.nrmse < 1.2 * bla


def test_a_random_odd_record_is_validated_on_its_own_period():
    """The random-odd record's segment declares period = 16384 and is predicted in periodic steady state."""
    config = _config(periods=2, validation=("random-odd level 2",), stop_periods=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # non-physical poles of the linear part, discarded
        signals, segments = load_signals(config), load_validation(config)
        result = identify(signals, CandidateModel("linear", ()), config.nsi.replace(order=14))
    (name, odd), = segments
    assert odd.period == 16384 and odd.n_samples == 2 * 16384
    # integrated over the fitted band only (the segment's own integrate): nothing above 15 Hz
    spectrum = np.abs(np.fft.rfft(odd.displacement, axis=0))
    freqs = np.fft.rfftfreq(odd.n_samples, 1.0 / odd.fs)
    assert spectrum[freqs > 15.01].max() < 1e-9 * spectrum.max()
    (found,) = validate(result, segments)
    assert found.error is None and 0 < found.nrmse < 1
