"""Default priors of a candidate, set from the data before the fit (docs/method.md §6).

Coefficient scales ``s_i = F_ref / rms(n_i)`` (a coefficient one standard deviation from zero
makes the term's force as large as a reference force), noise ranges from the measured channels'
spread, AR coefficients inside the stationary range; the prior types are in :mod:`.priors`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..exceptions import InputDataError
from .priors import ARPrior, CoefficientPrior, NoisePrior, Priors

__all__ = ["coefficient_prior", "default_coefficient_scales", "default_priors"]


def default_coefficient_scales(term_rms, reference_force_rms) -> np.ndarray:
    """Default prior scales ``s_i = F_ref / rms(n_i)`` (docs/method.md §6).

    With this scale a coefficient one standard deviation from zero makes the term's force
    ``λ_i n_i(x, ẋ)`` as large (in RMS) as the reference force, typically the linear restoring
    force at the measured amplitude, e.g. ``k · rms(x)`` at the term's location.

    Parameters
    ----------
    term_rms : array_like, shape (q,)
        RMS of each nonlinear function ``n_i`` evaluated on the measured data (the extended
        input columns), in its own units.
    reference_force_rms : float or array_like, shape (q,)
        Reference force RMS [N], one for all terms or one per term.

    Returns
    -------
    ndarray, shape (q,)
    """
    term_rms = np.atleast_1d(np.asarray(term_rms, dtype=float))
    ref = np.broadcast_to(np.asarray(reference_force_rms, dtype=float), term_rms.shape)
    if not np.all(np.isfinite(term_rms) & (term_rms > 0)):
        raise InputDataError(f"term RMS values must be positive and finite, got {term_rms}")
    if not np.all(np.isfinite(ref) & (ref > 0)):
        raise InputDataError(f"reference force RMS must be positive and finite, got {ref}")
    return ref / term_rms


def coefficient_prior(
    names: Sequence[str], term_rms, reference_force_rms, overrides: Mapping[str, float] | None = None
) -> CoefficientPrior:
    """Default coefficient prior with optional per-term overrides.

    Parameters
    ----------
    names : sequence of str
        Term names, length ``q``.
    term_rms, reference_force_rms
        See :func:`default_coefficient_scales`.
    overrides : mapping of str to float, optional
        Prior scales set by the user for some terms.

    Returns
    -------
    CoefficientPrior
    """
    scale = default_coefficient_scales(term_rms, reference_force_rms)
    ref = np.atleast_1d(np.asarray(reference_force_rms, dtype=float))
    ref_text = f"{ref[0]:.4g}" if ref.size == 1 else "per term"
    prior = CoefficientPrior(
        names=tuple(names),
        scale=scale,
        source=f"scale = reference force RMS ({ref_text}) / rms(n_i)",
    )
    return prior.with_scales(overrides) if overrides else prior


def default_priors(
    affine,
    term_rms,
    reference_force_rms,
    overrides: Mapping[str, float] | None = None,
    channel_names: Sequence[str] = (),
    noise_factors: tuple[float | np.ndarray, float] = (1e-4, 10.0),
    ar_bounds: tuple[float, float] = (-0.9999, 0.9999),
) -> Priors:
    """The default priors of docs/method.md §6 for an affine reconstruction.

    Parameters
    ----------
    affine : AffineReconstruction
        Supplies the term names and ``std`` of the measured channels.
    term_rms, reference_force_rms
        See :func:`default_coefficient_scales`.
    overrides : mapping of str to float, optional
        Per-term coefficient prior scales.
    channel_names : sequence of str, optional
    noise_factors : (float, float)
        ``σ_j`` range as multiples of ``std(y_j)``.
    ar_bounds : (float, float)
        Bounds of each AR coefficient.

    Returns
    -------
    Priors
    """
    measured = np.asarray(affine.measured, dtype=float)
    std = measured.reshape(len(measured), -1).std(axis=0)
    return Priors(
        coefficients=coefficient_prior(affine.names, term_rms, reference_force_rms, overrides),
        noise=NoisePrior.from_std(std, *noise_factors, channel_names=channel_names),
        ar=ARPrior(*ar_bounds),
    )
