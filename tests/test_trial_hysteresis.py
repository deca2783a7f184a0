"""A new user's trial on a Bouc-Wen-like hysteretic record (nonlinearbenchmark.org's layout).

The benchmark drives its system with a full random-phase multisine (every line of 5-150 Hz), ships
input and output as separate headerless single-column files, and its hysteresis has internal
state that no static n(y, ydot) represents. Each test pins a problem the trial found
(the simulation and the measured numbers are in the trial report, /tmp/bwtrial).
"""

from __future__ import annotations

import matplotlib
import numpy as np

matplotlib.use("Agg")

from bayesnsi.cli._report_periodic import HEADING, periodic_section
from bayesnsi.io.report import Report
from bayesnsi.signals import Signals

FS, P = 200.0, 512


def _full_multisine_record(seed: int = 0) -> Signals:
    """A one-DOF linear oscillator (2 kg, 1e5 N/m, 10 N s/m) driven by a full random-phase multisine.

    Every DFT line of 5-60 Hz is excited, so no line inside the band is left empty. The response is
    computed independently of bayesnsi: the exact periodic steady state, line by line, from
    H(jw) = 1 / (k - m w^2 + j c w).
    """
    rng = np.random.default_rng(seed)
    k = np.arange(P // 2 + 1)
    freqs = k * FS / P
    excited = (freqs >= 5.0) & (freqs <= 60.0)
    spectrum = np.where(excited, np.exp(2j * np.pi * rng.random(k.size)), 0.0)
    w = 2 * np.pi * freqs
    h = 1.0 / (1e5 - 2.0 * w**2 + 10j * w)
    force = np.fft.irfft(spectrum, P)
    force *= 10.0 / force.std()
    disp = np.fft.irfft(np.fft.rfft(force) * h, P)
    n_periods = 4
    x = np.tile(disp, n_periods)
    x = x + 0.02 * x.std() * rng.standard_normal(x.size)
    return Signals(force=np.tile(force, n_periods)[:, None], displacement=x[:, None], fs=FS,
                   input_dofs=(1,), output_dofs=(1,), period=P)


def test_distortion_level_of_a_full_multisine_is_stated_as_not_measurable_not_nan():
    # Before: "the response at the lines the force leaves empty is up to nan times its noise level".
    report = Report("t")
    assert periodic_section(report, _full_multisine_record())
    blocks = next(b for _, name, b in report.sections if name == HEADING)
    text = next(b for b in blocks if isinstance(b, str) and b.startswith("Distortion level"))
    assert "nan" not in text.lower()
    assert "not measurable" in text and "excites every line" in text


def test_distortion_level_names_the_kind_of_unexcited_lines_it_measured():
    from bayesnsi.cli._report_periodic import distortion_text

    text = distortion_text({"odd": np.array([np.nan]), "even": np.array([1.04])}, 4, 1, 100)
    assert "nan" not in text.lower() and "1.04 times its noise level at the unexcited even lines" in text
