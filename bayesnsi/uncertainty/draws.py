"""Draws that carry the honest intervals, for the posterior files (docs/posterior-files.md).

The intervals of :func:`~bayesnsi.uncertainty.candidate_intervals` are quantiles: a centre, a 50 %
and a 95 % interval per parameter. A tool that reads posterior draws (arviz's ``summary``,
``plot_dist``) should find the same intervals there. :func:`interval_draws` gives every draw of the
posterior given the linear part a new value by its rank: the rank ``r`` of a draw among ``N`` is
the probability ``p = (r + 1/2) / N``, mapped to the standard normal ``z = Φ⁻¹(p)`` and from there,
piecewise linearly in ``z``, onto the interval's 2.5 %, 25 %, 50 %, 75 % and 97.5 % points (the
outer slopes continue beyond them). Each marginal then has exactly the honest quantiles, while the
dependence between the coefficients (their ranks, a Gaussian copula) and the chains' order stay
those of the posterior.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtri

__all__ = ["interval_draws"]

_Z = np.array([ndtri(0.025), ndtri(0.25), 0.0, ndtri(0.75), ndtri(0.975)])


def _quantile_points(p) -> np.ndarray:
    """The 2.5 %, 25 %, 50 %, 75 % and 97.5 % points of a :class:`ParameterInterval`."""
    centre = p.estimate - p.bias if math.isfinite(p.bias) else 0.5 * (p.ci50[0] + p.ci50[1])
    points = np.array([p.ci95[0], p.ci50[0], centre, p.ci50[1], p.ci95[1]], dtype=float)
    return np.maximum.accumulate(points)  # a centre stretched outside the 50 % interval stays ordered


def interval_draws(parameters, draws) -> np.ndarray:
    """Draws with the honest quantiles of ``parameters``, ranked as ``draws`` (module notes).

    Parameters
    ----------
    parameters : sequence of ParameterInterval
        One per column of ``draws`` (e.g. ``Intervals.coefficients``).
    draws : ndarray, shape (chain, draw, q)
        Posterior draws given the linear part (their ranks are kept).

    Returns
    -------
    ndarray, shape (chain, draw, q)
        For each parameter, draws whose 2.5, 25, 50, 75 and 97.5 % quantiles are its interval's
        bounds and centre (exactly, up to the ranks' discreteness); NaN for a parameter whose
        interval is not finite.
    """
    draws = np.asarray(draws, dtype=float)
    chains, n_draws, q = draws.shape
    flat = draws.reshape(chains * n_draws, q)
    out = np.empty_like(flat)
    n = len(flat)
    for k, p in enumerate(parameters):
        points = _quantile_points(p)
        if not np.all(np.isfinite(points)):
            out[:, k] = np.nan
            continue
        ranks = np.empty(n)
        ranks[np.argsort(flat[:, k], kind="stable")] = np.arange(n)
        z = ndtri((ranks + 0.5) / n)
        out[:, k] = _piecewise(z, points)
    return out.reshape(chains, n_draws, q)


def _piecewise(z: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Linear in ``z`` through (``_Z``, ``points``), extended with the outer slopes."""
    inside = np.interp(z, _Z, points)
    low_slope = (points[1] - points[0]) / (_Z[1] - _Z[0])
    high_slope = (points[4] - points[3]) / (_Z[4] - _Z[3])
    return np.where(z < _Z[0], points[0] + (z - _Z[0]) * low_slope,
                    np.where(z > _Z[4], points[4] + (z - _Z[4]) * high_slope, inside))
