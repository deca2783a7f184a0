"""Synthetic posterior draws and loop steps for the figure, report and posterior-file tests."""

import numpy as np

from bayesnsi.evidence.posterior import PosteriorSamples
from bayesnsi.models import Term


class LoopStep:  # what plot_effect_force reads from a loop step without a residual force
    def __init__(self, expr, at, coefficient):
        self.term, self.coefficient = Term(expr, at), coefficient


def posterior_samples(q, n_chains=32, n_draws=120):
    """Gaussian draws of ``q`` coefficients and one noise parameter (channel x1), seeded."""
    rng = np.random.default_rng(2)
    names = tuple(f"term {k}" for k in range(q))
    samples = rng.normal(size=(n_chains, n_draws, q + 1))
    return PosteriorSamples(
        samples=samples,
        log_posterior=-0.5 * (samples**2).sum(axis=-1),
        param_names=names + ("log sigma x1",),
        coefficient_names=names,
        channel_names=("x1",),
        likelihood="white",
        ar_order=0,
        acceptance_fraction=np.full(n_chains, 0.4),
        autocorr_time=np.ones(q + 1),
        autocorr_reliable=True,
        mode=np.zeros(q + 1),
        mode_covariance=np.eye(q + 1),
    )
