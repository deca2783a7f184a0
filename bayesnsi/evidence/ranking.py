"""Posterior model probabilities and the paper's plain ranking (docs/method.md §6; paper Eqs. 1-4).

Bayes' rule over a finite candidate set ``μ_1..μ_S`` (paper Eq. 1):

.. math:: P(μ_i|D) = \\frac{p(D|μ_i) P(μ_i)}{\\sum_k p(D|μ_k) P(μ_k)}

* plain ranking (paper Eqs. 2-4): ``p(D|μ_i)`` replaced by the Gaussian likelihood at the
  maximum-likelihood noise level, ``log L_i = -(n/2)(log 2πσ̂_i² + 1)``, ``P(μ_i) = 1/S``. For nested
  candidates the larger always wins, and with thousands of samples it saturates at 0/100 %;
* evidence ranking: ``p(D|μ_i) = Z_i`` (:mod:`~bayesnsi.evidence.marginal`), whose Occam factor
  penalises coefficients the data do not need. Its Monte-Carlo uncertainty is propagated by
  drawing ``log Z_i ~ N(log Ẑ_i, se_i²)``.

Failed candidates (``log Z = -inf`` or NaN) get probability 0. These are posterior model
probabilities, not predictive (LOO) weights: arviz's ``compare`` stacking weights answer a
different question and pointwise LOO is invalid for autocorrelated time series (EVIDENCE.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..exceptions import InputDataError, ShapeError

__all__ = ["ModelProbabilities", "posterior_probabilities", "plain_ranking", "ranking_table", "compare_evidence"]


@dataclass(frozen=True)
class ModelProbabilities:
    """Posterior probabilities of a candidate set.

    Attributes
    ----------
    names : tuple of str
        Candidate names, length ``S``.
    probability : ndarray, shape (S,)
        ``P(μ_i|D)``; NaN for all if every candidate failed.
    probability_sd : ndarray, shape (S,)
        Monte-Carlo standard deviation of each probability (0 for the plain ranking).
    log_score : ndarray, shape (S,)
        ``log Z_i`` or ``log L_i`` used.
    log_score_se : ndarray, shape (S,)
        Standard errors of ``log_score`` (0 where none given).
    prior : ndarray, shape (S,)
        Normalised prior model probabilities ``P(μ_i)``.
    method : str
        ``"evidence"`` or ``"plain"``.
    """

    names: tuple[str, ...]
    probability: np.ndarray
    probability_sd: np.ndarray
    log_score: np.ndarray
    log_score_se: np.ndarray
    prior: np.ndarray
    method: str

    @property
    def best(self) -> str:
        """Name of the most probable candidate."""
        return self.names[int(np.nanargmax(self.probability))]


def posterior_probabilities(
    log_evidences,
    priors=None,
    log_evidence_se=None,
    names: Sequence[str] | None = None,
    rng=None,
    n_draws: int = 2000,
) -> ModelProbabilities:
    """Posterior model probabilities from log evidences (paper Eq. 1), with MC uncertainty.

    Parameters
    ----------
    log_evidences : array_like, shape (S,)
        ``log Z_i`` [nat]; ``-inf`` or NaN marks a failed candidate (probability 0).
    priors : array_like, shape (S,), optional
        Prior model probabilities or weights (normalised here); default ``1/S`` (paper Eq. 2).
    log_evidence_se : array_like, shape (S,), optional
        Monte-Carlo standard errors of ``log Z_i``; default 0.
    names : sequence of str, optional
        Candidate names (default ``"M0", "M1", ...``).
    rng : int or numpy.random.Generator, optional
        For the ``n_draws`` perturbed evidence sets.
    n_draws : int, default 2000
        Number of draws ``log Z ~ N(log Ẑ, se²)`` for the standard deviation of each probability.

    Returns
    -------
    ModelProbabilities
    """
    log_z, prior, candidates = _normalise(log_evidences, priors, names)
    se = np.zeros_like(log_z) if log_evidence_se is None else np.asarray(log_evidence_se, dtype=float).reshape(-1)
    if se.shape != log_z.shape:
        raise ShapeError(f"log_evidence_se has shape {se.shape}, expected {log_z.shape}")
    se = np.where(np.isfinite(log_z), se, 0.0)
    if np.any(se < 0):
        raise InputDataError(f"standard errors must be >= 0, got {se}")
    prob = _softmax(log_z + _log(prior))
    rng = np.random.default_rng(rng)
    if np.any(se > 0) and np.any(np.isfinite(log_z)):
        draws = log_z + se * rng.standard_normal((int(n_draws), log_z.size))
        sd = np.std(_softmax(draws + _log(prior)), axis=0, ddof=1)
    else:
        sd = np.zeros_like(prob)
    return ModelProbabilities(
        names=candidates, probability=prob, probability_sd=sd, log_score=log_z, log_score_se=se, prior=prior,
        method="evidence",
    )


def plain_ranking(log_likelihoods, priors=None, names: Sequence[str] | None = None) -> ModelProbabilities:
    """The paper's ranking: ``P(μ_i|D) ∝ L_i P(μ_i)`` with the ML Gaussian likelihood (Eqs. 1-4).

    Parameters
    ----------
    log_likelihoods : array_like, shape (S,)
        ``log L_i = Σ_j -(n/2)(log 2πσ̂_{ij}² + 1)`` (:func:`~bayesnsi.evidence.plain_log_likelihood`).
    priors : array_like, shape (S,), optional
        Prior model probabilities (default ``1/S``, Eq. 2).
    names : sequence of str, optional

    Returns
    -------
    ModelProbabilities
        ``probability_sd`` is 0: the plain ranking has no Monte-Carlo error.
    """
    log_l, prior, candidates = _normalise(log_likelihoods, priors, names)
    prob = _softmax(log_l + _log(prior))
    return ModelProbabilities(
        names=candidates, probability=prob, probability_sd=np.zeros_like(prob), log_score=log_l,
        log_score_se=np.zeros_like(prob), prior=prior, method="plain",
    )


def ranking_table(
    names: Sequence[str],
    plain_log_likelihoods=None,
    evidence: Mapping[str, tuple] | None = None,
    priors=None,
    rng=None,
    n_draws: int = 2000,
):
    """Plain ranking and evidence-based posterior probabilities side by side (docs/method.md §6).

    Parameters
    ----------
    names : sequence of str
        Candidate names, length ``S``.
    plain_log_likelihoods : array_like, shape (S,), optional
        Paper Eq. 4 values.
    evidence : mapping of str to (log_evidences, log_evidence_se)
        One entry per likelihood (e.g. ``{"white": (...), "ar1": (...)}``), each two arrays of
        shape (S,), so the change of the probabilities with the noise model shows.
    priors : array_like, shape (S,), optional
        Prior model probabilities (default uniform).
    rng : int or numpy.random.Generator, optional
    n_draws : int, default 2000

    Returns
    -------
    pandas.DataFrame
        Index ``candidate``; columns ``prior``, ``log_likelihood_plain``, ``p_plain``, and for each
        likelihood ``L``: ``log_evidence_L``, ``log_evidence_se_L``, ``p_L``, ``p_L_sd``.
    """
    import pandas as pd

    rng = np.random.default_rng(rng)
    names = tuple(str(n) for n in names)
    columns: dict[str, np.ndarray] = {}
    prior = None
    if plain_log_likelihoods is not None:
        plain = plain_ranking(plain_log_likelihoods, priors, names)
        prior = plain.prior
        columns["log_likelihood_plain"] = plain.log_score
        columns["p_plain"] = plain.probability
    for label, (log_z, se) in (evidence or {}).items():
        post = posterior_probabilities(log_z, priors, se, names, rng=rng, n_draws=n_draws)
        prior = post.prior
        columns[f"log_evidence_{label}"] = post.log_score
        columns[f"log_evidence_se_{label}"] = post.log_score_se
        columns[f"p_{label}"] = post.probability
        columns[f"p_{label}_sd"] = post.probability_sd
    if prior is None:
        raise InputDataError("ranking_table needs plain_log_likelihoods or evidence")
    table = pd.DataFrame({"prior": prior, **columns}, index=pd.Index(names, name="candidate"))
    return table


def compare_evidence(results: Mapping[str, Any], priors=None, rng=None, n_draws: int = 2000):
    """:func:`ranking_table` from evidence results.

    Parameters
    ----------
    results : mapping of candidate name to EvidenceResult, sequence of EvidenceResult, or None
        Several results per candidate (one per likelihood) give one column group each; None marks
        a failed candidate.
    priors : array_like, shape (S,), optional
    rng : int or numpy.random.Generator, optional
    n_draws : int, default 2000

    Returns
    -------
    pandas.DataFrame
    """
    names = list(results)
    per = {
        name: ([] if r is None else (list(r) if isinstance(r, (list, tuple)) else [r])) for name, r in results.items()
    }
    labels: list[str] = []
    for rs in per.values():
        for r in rs:
            if r.likelihood not in labels:
                labels.append(r.likelihood)
    plain = np.full(len(names), -np.inf)
    evidence = {lab: (np.full(len(names), -np.inf), np.zeros(len(names))) for lab in labels}
    for i, name in enumerate(names):
        for r in per[name]:
            plain[i] = r.plain_log_likelihood
            evidence[r.likelihood][0][i] = r.log_evidence
            evidence[r.likelihood][1][i] = r.log_evidence_se
    return ranking_table(names, plain, evidence, priors, rng, n_draws)


def _normalise(scores, priors, names) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    scores = np.asarray(scores, dtype=float).reshape(-1)
    if scores.size == 0:
        raise InputDataError("no candidates to rank")
    scores = np.where(np.isnan(scores), -np.inf, scores)
    if np.any(scores == np.inf):
        raise InputDataError(f"a log evidence/likelihood is +inf: {scores}")
    if priors is None:
        prior = np.full(scores.size, 1.0 / scores.size)
    else:
        prior = np.asarray(priors, dtype=float).reshape(-1)
        if prior.shape != scores.shape:
            raise ShapeError(f"{prior.size} prior probabilities for {scores.size} candidates")
        if np.any(prior < 0) or not np.isfinite(prior).all() or prior.sum() <= 0:
            raise InputDataError(f"prior model probabilities must be >= 0 with a positive sum, got {prior}")
        prior = prior / prior.sum()
    names = tuple(f"M{i}" for i in range(scores.size)) if names is None else tuple(str(n) for n in names)
    if len(names) != scores.size:
        raise ShapeError(f"{len(names)} names for {scores.size} candidates")
    return scores, prior, names


def _log(x: np.ndarray) -> np.ndarray:
    """``log`` with ``log 0 = -inf`` and no warning."""
    with np.errstate(divide="ignore"):
        return np.log(x)


def _softmax(x: np.ndarray) -> np.ndarray:
    """Softmax along the last axis with ``-inf`` entries mapping to 0 (all ``-inf``: NaN)."""
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore"):
        top = np.max(x, axis=-1, keepdims=True)
    finite = np.isfinite(top)
    shifted = np.where(finite, x - np.where(finite, top, 0.0), -np.inf)
    e = np.exp(shifted)
    total = e.sum(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore"):
        return np.where(total > 0, e / np.where(total > 0, total, 1.0), np.nan)
