"""Synthetic affine reconstructions ``y = ŷ₀ + G λ + e`` and their priors, for the evidence tests."""

import numpy as np
from scipy.signal import lfilter

from bayesnsi.evidence import CoefficientPrior, NoisePrior, Priors
from bayesnsi.nsi import AffineReconstruction


def make_affine(n_samples, n_channels, q, rng, sigma=0.5, rho=0.0, coefficients=None, smooth=False):
    """Synthetic affine reconstruction ``y = ŷ₀ + G λ + e`` with Gaussian (AR(1)) noise ``e``.

    The NSI estimate is replaced by the least-squares estimate, as NSI would give.
    """
    g = rng.standard_normal((n_samples, n_channels, q))
    if smooth:  # low-pass signatures, like structural responses
        kernel = np.hanning(15)
        g = np.apply_along_axis(lambda x: np.convolve(x, kernel, mode="same"), 0, g)
    lam = rng.standard_normal(q) if coefficients is None else np.asarray(coefficients, dtype=float)
    noise = sigma * rng.standard_normal((n_samples, n_channels))
    if rho:  # stationary AR(1): e_0 ~ N(0, σ²/(1-ρ²)), e_t = ρ e_{t-1} + w_t
        noise[0] /= np.sqrt(1 - rho**2)
        noise = lfilter([1.0], [1.0, -rho], noise, axis=0)
    baseline = rng.standard_normal((n_samples, n_channels))
    measured = baseline + g @ lam + noise
    ls = np.linalg.lstsq(g.reshape(-1, q), (measured - baseline).reshape(-1), rcond=None)[0] if q else lam
    return AffineReconstruction(
        measured=measured, baseline=baseline, signatures=g, estimate=ls, names=tuple(f"k{i}" for i in range(q))
    )


def make_priors(affine, scale=3.0):
    q = affine.signatures.shape[2]
    return Priors(
        coefficients=CoefficientPrior(affine.names, np.full(q, scale)),
        noise=NoisePrior.from_std(affine.measured.std(axis=0)),
    )
