"""How far the identification itself can move: intervals that carry the linear part's uncertainty.

The coefficient posterior of the evidence is conditional on the identified linear part, which it
treats as exact (docs/method.md §11). The intervals here repeat the whole identification:

- :mod:`~bayesnsi.uncertainty.replicates`: on copies of the record with fresh sensor noise drawn
  from its noise model (scatter and errors-in-variables bias);
- :mod:`~bayesnsi.uncertainty.surrogate`: on records of the identified model driven by
  phase-randomised forces (model replicates, for Coulomb friction);
- :mod:`~bayesnsi.uncertainty.windows`: on sub-record windows;
- :mod:`~bayesnsi.uncertainty.intervals`: the combination of either with the posterior into
  50 % / 95 % intervals of coefficients and modes (:func:`candidate_intervals`);
- :mod:`~bayesnsi.uncertainty.draws`: draws that carry those intervals (the posterior files);
- :mod:`~bayesnsi.uncertainty.widening`: intervals of inadequate models widened by their model error.
"""

from .intervals import INTERVAL_METHODS, Intervals, ParameterInterval, candidate_intervals
from .replicates import discontinuity_findings, match_modes, noise_replicates, reidentify, replicate_moments
from .surrogate import holds_coulomb_friction, model_replicates, surrogate_forces, surrogate_problem
from .widening import widen, widen_final, widen_inadequate
from .windows import segment_estimates

__all__ = [
    "INTERVAL_METHODS",
    "Intervals",
    "ParameterInterval",
    "candidate_intervals",
    "discontinuity_findings",
    "holds_coulomb_friction",
    "match_modes",
    "model_replicates",
    "noise_replicates",
    "reidentify",
    "replicate_moments",
    "segment_estimates",
    "surrogate_forces",
    "surrogate_problem",
    "widen",
    "widen_final",
    "widen_inadequate",
]
