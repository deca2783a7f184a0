"""Evidence of an identified NSI candidate: priors from the data, one result per likelihood."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..options import EvidenceOptions
from ._target import parse_likelihood
from .likelihood import sufficient_statistics
from .marginal import evidence_from_statistics
from .pointwise import block_statistics
from .prior_defaults import default_priors

__all__ = ["RESIDUALS", "candidate_affine", "candidate_evidence", "candidate_priors", "noise_floor_factor"]

RESIDUALS = ("reconstruction", "innovations", "force")
"""Residuals the evidence can be built on: the open-loop reconstruction error (the paper's) or
the one-step-ahead innovations of the errors-in-variables Kalman predictor
(:func:`bayesnsi.nsi.predictor_reconstruction`), or the force predicted from the measured motion
(:func:`bayesnsi.nsi.force_affine`, one-DOF models; always used for a free body, whose displacement
residual is dominated by the drift of its rigid-body mode)."""


def candidate_priors(result, signals, affine, options: EvidenceOptions | None = None, candidate=None):
    """Default priors of docs/method.md §6 for one identified candidate (per-term overrides honoured).

    Parameters
    ----------
    result : NSIResult
    signals : Signals
    affine : AffineReconstruction
        From :func:`candidate_affine`.
    options : EvidenceOptions, optional
        ``reference_force_rms`` scales the coefficient priors.
    candidate : CandidateModel, optional
        Carries per-term prior scales (default ``result.candidate``).

    Returns
    -------
    Priors
    """
    options = options or EvidenceOptions()
    candidate = candidate or result.candidate
    u = result.extended_input(signals)
    m = len(result.input_dofs)
    term_rms = np.sqrt(np.mean(u[:, m:] ** 2, axis=0))
    force_ref = options.reference_force_rms or float(
        np.sqrt(np.sum(np.mean(np.asarray(signals.force) ** 2, axis=0)))
    )
    overrides = {t.name: s for t, s in zip(candidate.terms, candidate.coefficient_prior_scales) if s is not None}
    floor = options.noise_floor if options.noise_floor is not None else noise_floor_factor(affine.measured)
    return default_priors(
        affine, term_rms, force_ref, overrides=overrides, channel_names=signals.output_names,
        noise_factors=(floor, 10.0),
    )


def noise_floor_factor(measured) -> np.ndarray:
    """Default lower end of the noise prior per channel, as a multiple of ``std(y_j)``.

    ``min(1e-4, 0.1 σ_white,j / std(y_j))`` with ``σ_white`` the output's white-noise level from
    high-order differences (:func:`bayesnsi.nsi.white_noise_std`): a data-only bound, the same for
    every candidate, that stays below the residual of precise records (a positioning axis at 1 kHz
    has residuals near 1e-5 of the travel).

    Parameters
    ----------
    measured : ndarray, shape (n_samples, l)
        The measured outputs.

    Returns
    -------
    ndarray, shape (l,)
    """
    from ..noise import white_noise_std

    y = np.asarray(measured, dtype=float).reshape(len(measured), -1)
    std = y.std(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = 0.1 * white_noise_std(y) / std
    return np.where(np.isfinite(ratio) & (ratio > 0), np.minimum(1e-4, ratio), 1e-4)


def candidate_affine(result, signals, residual: str = "innovations"):
    """The affine model ``ŷ(λ)`` whose residual the evidence scores (docs/method.md §6).

    ``"reconstruction"``: the open-loop reconstruction (:func:`bayesnsi.nsi.affine_reconstruction`),
    whose residual is the paper's. ``"innovations"``: the one-step-ahead predictor that accounts
    for the measurement noise carried into the nonlinear inputs
    (:func:`bayesnsi.nsi.predictor_reconstruction`); it does not count that propagated noise
    as misfit, which a spurious superset term would otherwise absorb (docs/method.md §10).

    Parameters
    ----------
    result : NSIResult
        The identified candidate.
    signals : Signals
        The estimation data.
    residual : {"innovations", "reconstruction", "force"}
        Which residual (see :data:`RESIDUALS`); a free body (``result.virtual_stiffness > 0``, one
        DOF) is always scored on the force residual.

    Returns
    -------
    AffineReconstruction

    Raises
    ------
    ConfigError
        When ``residual`` is unknown.
    """
    from ..exceptions import ConfigError
    from ..nsi import affine_reconstruction, is_free_body, predictor_reconstruction

    if residual not in RESIDUALS:
        raise ConfigError(f"[evidence] residual {residual!r} unknown; use one of {list(RESIDUALS)}")
    if residual == "force" or is_free_body(result):
        # a free body (rigid-body pole): scored on the force it predicts from the measured motion
        from ..nsi import force_affine

        return force_affine(result, signals, profile=True)
    if residual == "reconstruction":
        return affine_reconstruction(result, signals)
    if residual == "innovations":
        return predictor_reconstruction(result, signals)
    raise ConfigError(f"[evidence] residual {residual!r} unknown; use one of {list(RESIDUALS)}")


def candidate_evidence(
    result, signals, options: EvidenceOptions | None = None, seed_sequence=None, candidate=None, *, warn: bool = True,
    reconstruction=None, affine=None,
):
    """Marginal evidence of one identified candidate under each requested likelihood.

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        The estimation data the result was identified from.
    options : EvidenceOptions, optional
        Residual, likelihoods and emcee sizes (default ``EvidenceOptions()``).
    seed_sequence : numpy.random.SeedSequence, optional
        One child per likelihood is spawned from it (reproducible whatever the order of runs).
    candidate : CandidateModel, optional
        Carries per-term prior scales (default ``result.candidate``).
    warn : bool
        Warn when a chain did not converge (:func:`marginal_evidence`).
    reconstruction : Reconstruction, optional
        ``result.reconstruct(signals)`` when the caller has it already (the paper's plain
        likelihood is read from it; computed here otherwise).
    affine : AffineReconstruction, optional
        ``candidate_affine(result, signals, options.residual)`` when the caller has it already
        (computed here otherwise).

    Returns
    -------
    dict likelihood -> EvidenceResult
    """
    options = options or EvidenceOptions()
    if not isinstance(options, EvidenceOptions):
        raise TypeError(f"options must be EvidenceOptions, got {type(options).__name__}")
    seed_sequence = seed_sequence or np.random.SeedSequence(0)
    residual = options.residual
    affine = candidate_affine(result, signals, residual) if affine is None else affine
    priors = candidate_priors(result, signals, affine, options, candidate)
    plain = None
    if residual != "reconstruction":
        # the paper's plain ranking (Eq. 4) always scores the open-loop reconstruction residual
        from .likelihood import plain_log_likelihood

        reconstruction = reconstruction if reconstruction is not None else result.reconstruct(signals)
        plain = plain_log_likelihood(reconstruction.measured - reconstruction.predicted)
    likelihoods = options.likelihoods
    orders = {lik: parse_likelihood(lik)[0] for lik in likelihoods}
    # one pass over the record serves every likelihood: statistics of order p hold those of lower orders
    t0 = time.perf_counter()
    stats = sufficient_statistics(affine, ar_order=max(orders.values()))
    blocks = block_statistics(affine, ar_order=max(orders.values()))  # the draws' pointwise log-likelihood
    t_stats = time.perf_counter() - t0
    out = {}
    for lik, child in zip(likelihoods, seed_sequence.spawn(len(likelihoods))):
        ar_order = orders[lik]
        # white and AR(1): the noise parameters are integrated out and emcee samples the coefficients alone
        n_params = len(affine.names) + (0 if ar_order <= 1 else affine.measured.shape[1] * (1 + ar_order))
        n_walkers = max(options.n_walkers, 2 * n_params + 2)  # emcee needs >= 2 x parameters
        ev = evidence_from_statistics(
            stats,
            priors,
            likelihood=lik,
            rng=np.random.default_rng(child),
            n_walkers=n_walkers + n_walkers % 2,
            n_steps=options.n_steps,
            n_burn=options.n_burn,
            warn=warn,
        )
        out[lik] = replace(ev, settings={**ev.settings, "time_statistics_s": t_stats}, blocks=blocks)
    if plain is not None:
        out = {lik: replace(ev, plain_log_likelihood=plain) for lik, ev in out.items()}
    return out
