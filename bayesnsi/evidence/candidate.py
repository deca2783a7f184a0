"""Evidence of an identified NSI candidate: priors from the data, one result per likelihood."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..options import EvidenceOptions
from .marginal import marginal_evidence
from .prior_defaults import default_priors

__all__ = ["RESIDUALS", "candidate_affine", "candidate_evidence", "candidate_priors"]

RESIDUALS = ("reconstruction", "innovations")
"""Residuals the evidence can be built on: the open-loop reconstruction error (the paper's) or
the one-step-ahead innovations of the errors-in-variables Kalman predictor
(:func:`bayesnsi.nsi.predictor_reconstruction`)."""


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
    return default_priors(affine, term_rms, force_ref, overrides=overrides, channel_names=signals.output_names)


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
    residual : {"innovations", "reconstruction"}
        Which residual (see :data:`RESIDUALS`).

    Returns
    -------
    AffineReconstruction

    Raises
    ------
    ConfigError
        When ``residual`` is unknown.
    """
    from ..exceptions import ConfigError
    from ..nsi import affine_reconstruction, predictor_reconstruction

    if residual == "reconstruction":
        return affine_reconstruction(result, signals)
    if residual == "innovations":
        return predictor_reconstruction(result, signals)
    raise ConfigError(f"[evidence] residual {residual!r} unknown; use one of {list(RESIDUALS)}")


def candidate_evidence(
    result, signals, options: EvidenceOptions | None = None, seed_sequence=None, candidate=None, *, warn: bool = True
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

    Returns
    -------
    dict likelihood -> EvidenceResult
    """
    options = options or EvidenceOptions()
    if not isinstance(options, EvidenceOptions):
        raise TypeError(f"options must be EvidenceOptions, got {type(options).__name__}")
    seed_sequence = seed_sequence or np.random.SeedSequence(0)
    residual = options.residual
    affine = candidate_affine(result, signals, residual)
    priors = candidate_priors(result, signals, affine, options, candidate)
    plain = None
    if residual != "reconstruction":
        # the paper's plain ranking (Eq. 4) always scores the open-loop reconstruction residual
        from .likelihood import plain_log_likelihood

        reconstruction = result.reconstruct(signals)
        plain = plain_log_likelihood(reconstruction.measured - reconstruction.predicted)
    likelihoods = options.likelihoods
    out = {}
    for lik, child in zip(likelihoods, seed_sequence.spawn(len(likelihoods))):
        ar_order = 0 if lik == "white" else int(lik[2:])
        n_params = len(affine.names) + affine.measured.shape[1] * (1 + ar_order)
        n_walkers = max(options.n_walkers, 2 * n_params + 2)  # emcee needs >= 2 x parameters
        out[lik] = marginal_evidence(
            affine,
            priors,
            likelihood=lik,
            rng=np.random.default_rng(child),
            n_walkers=n_walkers + n_walkers % 2,
            n_steps=options.n_steps,
            n_burn=options.n_burn,
            warn=warn,
        )
    if plain is not None:
        out = {lik: replace(ev, plain_log_likelihood=plain) for lik, ev in out.items()}
    return out
