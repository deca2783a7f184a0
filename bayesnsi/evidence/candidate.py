"""Evidence of an identified NSI candidate: priors from the data, one result per likelihood."""

from __future__ import annotations

import numpy as np

from .marginal import marginal_evidence
from .priors import default_priors

__all__ = ["EVIDENCE_DEFAULTS", "candidate_evidence", "candidate_priors"]

EVIDENCE_DEFAULTS = {
    "likelihood": "ar1",
    "compare": ["white"],
    "n_walkers": 32,
    "n_steps": 1500,
    "n_burn": 300,
    "reference_force_rms": None,
}
"""Settings of ``[evidence]``: primary likelihood, the others reported beside it, emcee sizes,
and the reference force of the default coefficient priors (None: rms of the measured forces)."""


def candidate_priors(result, signals, affine, options=EVIDENCE_DEFAULTS, candidate=None):
    """Default priors of SPEC 6 for one identified candidate (per-term overrides honoured)."""
    candidate = candidate or result.candidate
    u = result.extended_input(signals)
    m = len(result.input_dofs)
    term_rms = np.sqrt(np.mean(u[:, m:] ** 2, axis=0))
    force_ref = options.get("reference_force_rms") or float(
        np.sqrt(np.sum(np.mean(np.asarray(signals.force) ** 2, axis=0)))
    )
    overrides = {t.name: s for t, s in zip(candidate.terms, candidate.coefficient_prior_scales) if s is not None}
    return default_priors(affine, term_rms, force_ref, overrides=overrides, channel_names=signals.output_names)


def candidate_evidence(result, signals, options=EVIDENCE_DEFAULTS, seed_sequence=None, candidate=None, **extra):
    """Marginal evidence of one identified candidate under each requested likelihood.

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        The estimation data the result was identified from.
    options : mapping
        As :data:`EVIDENCE_DEFAULTS`.
    seed_sequence : numpy.random.SeedSequence, optional
        One child per likelihood is spawned from it (reproducible whatever the order of runs).
    candidate : CandidateModel, optional
        Carries per-term prior scales (default ``result.candidate``).
    **extra
        Passed to :func:`marginal_evidence` (e.g. ``warn=False``).

    Returns
    -------
    dict likelihood -> EvidenceResult
    """
    from ..nsi import affine_reconstruction

    seed_sequence = seed_sequence or np.random.SeedSequence(0)
    affine = affine_reconstruction(result, signals)
    priors = candidate_priors(result, signals, affine, options, candidate)
    likelihoods = [options["likelihood"]] + [lik for lik in options.get("compare", []) if lik != options["likelihood"]]
    out = {}
    for lik, child in zip(likelihoods, seed_sequence.spawn(len(likelihoods))):
        ar_order = 0 if lik == "white" else int(lik[2:])
        n_params = len(affine.names) + affine.measured.shape[1] * (1 + ar_order)
        n_walkers = max(int(options["n_walkers"]), 2 * n_params + 2)  # emcee needs >= 2 x parameters
        out[lik] = marginal_evidence(
            affine,
            priors,
            likelihood=lik,
            rng=np.random.default_rng(child),
            n_walkers=n_walkers + n_walkers % 2,
            n_steps=int(options["n_steps"]),
            n_burn=int(options["n_burn"]),
            **extra,
        )
    return out
