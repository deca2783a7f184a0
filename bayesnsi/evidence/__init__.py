"""Evidence and posterior model probabilities of NSI candidates (docs/method.md §6).

The only subpackage that uses emcee and arviz; they are imported when a sampling or summary
function runs, so ``import bayesnsi.evidence`` itself stays light, and ``import bayesnsi`` does not
import this package.

Workflow::

    stats = sufficient_statistics(affine, ar_order=1)           # one O(N q²) pass
    priors = default_priors(affine, term_rms, reference_force_rms)
    result = marginal_evidence(affine, priors, likelihood="ar1", rng=0)
    table = compare_evidence({"A": result_a, "B": result_b})   # beside the plain ranking

Conventions: posterior draws are ``(chain, draw, ...)`` with one chain per emcee walker; the
sampled noise parameter is ``log σ`` per output channel; log evidences are in nats.
"""

from .analytic import closed_form_log_evidence, laplace_log_evidence
from .bridge import BridgeEstimate, bridge_sampling
from .candidate import RESIDUALS, candidate_affine, candidate_evidence, candidate_priors
from .convergence import ConvergenceReport, convergence_report, posterior_summary, warn_if_unconverged
from .decision import decision_table, evidence_strength
from .likelihood import (
    SufficientStatistics,
    log_likelihood_ar,
    log_likelihood_white,
    plain_log_likelihood,
    sufficient_statistics,
)
from .marginal import EvidenceResult, evidence_from_statistics, marginal_evidence
from .pointwise import BlockStatistics, block_statistics, pointwise_log_likelihood
from .posterior import PosteriorSamples, SamplerRecord
from .prior_defaults import coefficient_prior, default_coefficient_scales, default_priors
from .priors import ARPrior, CoefficientPrior, NoisePrior, Priors
from .quadrature import QuadratureEvidence, quadrature_log_evidence
from .ranking import ModelProbabilities, compare_evidence, plain_ranking, posterior_probabilities, ranking_table
from .sampling import chain_bytes, check_chain_memory, sample_posterior

__all__ = [
    "BlockStatistics",
    "block_statistics",
    "pointwise_log_likelihood",
    # candidates
    "RESIDUALS",
    "candidate_affine",
    "candidate_evidence",
    "candidate_priors",
    # likelihood
    "SufficientStatistics",
    "sufficient_statistics",
    "log_likelihood_white",
    "log_likelihood_ar",
    "plain_log_likelihood",
    # priors
    "CoefficientPrior",
    "NoisePrior",
    "ARPrior",
    "Priors",
    "default_coefficient_scales",
    "coefficient_prior",
    "default_priors",
    # sampling
    "PosteriorSamples",
    "SamplerRecord",
    "sample_posterior",
    # evidence
    "EvidenceResult",
    "BridgeEstimate",
    "marginal_evidence",
    "evidence_from_statistics",
    "bridge_sampling",
    "chain_bytes",
    "check_chain_memory",
    "laplace_log_evidence",
    "closed_form_log_evidence",
    "QuadratureEvidence",
    "quadrature_log_evidence",
    # ranking
    "ModelProbabilities",
    "posterior_probabilities",
    "plain_ranking",
    "ranking_table",
    "compare_evidence",
    "decision_table",
    "evidence_strength",
    # convergence
    "ConvergenceReport",
    "posterior_summary",
    "convergence_report",
    "warn_if_unconverged",
]
