"""The reported coefficient and its interval are one estimate.

On the EMPS free body the loop's final Coulomb coefficient was reported as its NSI value 21.00
while its 95 % interval [18.4, 20.3] was centred on the posterior mean of the evidence (the
inverse model's estimate): the value lay outside its own interval. The intervals are now centred
on the reported NSI value (the estimate the record windows scatter about); the posterior mean is
kept beside it and a note says when it falls outside. Synthetic numbers with that geometry: a
posterior N(19.35, 0.2²) and windows scattered about the NSI value 21.0.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.options import EvidenceOptions
from bayesnsi.uncertainty import candidate_intervals
from bayesnsi.uncertainty import intervals as intervals_module

NSI_VALUE, POSTERIOR_MEAN, POSTERIOR_SD = 21.0, 19.35, 0.2
N, WINDOW = 10_000, 7_000


def _inputs():
    rng = np.random.default_rng(0)
    draws = rng.normal(POSTERIOR_MEAN, POSTERIOR_SD, size=(200, 16, 1))
    evidence = SimpleNamespace(posterior=SimpleNamespace(coefficients=draws), coefficient_names=("sign(v1)@1",))
    result = SimpleNamespace(coefficient_values=np.array([NSI_VALUE]), modes=())
    signals = SimpleNamespace(n_samples=N)
    return result, signals, evidence


@pytest.fixture
def windows(monkeypatch):
    """Eight windows of 70 % whose NSI estimates scatter by ±0.3 about the full-record value."""
    coefs = NSI_VALUE + 0.3 * np.array([[-1.0], [1.0], [-0.5], [0.5], [-0.2], [0.2], [0.0], [0.1]])

    def fake(result, signals, options=None, n_segments=8, fraction=0.7):
        return WINDOW, coefs, np.zeros((8, 0)), np.zeros((8, 0)), []

    monkeypatch.setattr(intervals_module, "segment_estimates", fake)
    return coefs


def test_segment_interval_is_centred_on_the_reported_nsi_value(windows):
    result, signals, evidence = _inputs()
    iv = candidate_intervals(result, signals, evidence, EvidenceOptions(interval="segments"))
    (p,) = iv.coefficients
    assert iv.method == "segments"
    assert p.estimate == NSI_VALUE
    assert p.ci95[0] < NSI_VALUE < p.ci95[1]  # failed before: [~18.4, ~20.3] about the posterior mean
    assert (p.ci95[0] + p.ci95[1]) / 2 == pytest.approx(NSI_VALUE)
    # the width is unchanged: posterior sd and the jackknife scatter of the windows, in quadrature
    scatter = np.sqrt(WINDOW / (N - WINDOW) * np.mean((windows[:, 0] - NSI_VALUE) ** 2))
    assert p.sd == pytest.approx(np.hypot(p.posterior_sd, scatter))
    assert p.posterior_mean == pytest.approx(POSTERIOR_MEAN, abs=0.01)
    assert any(f.kind == "interval.disagreement" and "sign(v1)@1" in f.message for f in iv.findings)
    assert p.to_dict()["posterior_mean"] == p.posterior_mean


def test_posterior_only_interval_is_the_posterior_spread_about_the_nsi_value():
    result, signals, evidence = _inputs()
    iv = candidate_intervals(result, signals, evidence, EvidenceOptions(interval="posterior"))
    (p,) = iv.coefficients
    assert p.estimate == NSI_VALUE and p.ci95[0] < NSI_VALUE < p.ci95[1]
    assert p.ci95[1] - p.ci95[0] == pytest.approx(2 * 1.96 * POSTERIOR_SD, rel=0.05)
    assert iv.findings  # 19.35 is 8 sd from 21.0: said, not hidden


def test_no_note_when_the_estimators_agree(windows):
    result, signals, evidence = _inputs()
    result = SimpleNamespace(coefficient_values=np.array([POSTERIOR_MEAN + 0.1]), modes=())
    iv = candidate_intervals(result, signals, evidence, EvidenceOptions(interval="segments"))
    assert not iv.findings
