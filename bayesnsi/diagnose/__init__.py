"""Closing the loop on measured data (docs/method.md §7): find what the model lacks, add it.

Modules: :mod:`~bayesnsi.diagnose.search` (the loop), :mod:`~bayesnsi.diagnose.scoring` (Laplace
evidence of each effect, the screen, clearance gaps), :mod:`~bayesnsi.diagnose.guards` (the one
acceptance rule: Bayes factor, quality index, record halves (:mod:`~bayesnsi.diagnose.halves`),
separability, dissipation), :mod:`~bayesnsi.diagnose.moves` (prune, look
ahead, re-examine), :mod:`~bayesnsi.diagnose.state` (the loop's context and state),
:mod:`~bayesnsi.diagnose.results`, :mod:`~bayesnsi.diagnose.screen`, :mod:`~bayesnsi.diagnose.forces`,
:mod:`~bayesnsi.diagnose.final` (evidence and honest intervals of the final model),
:mod:`~bayesnsi.diagnose.friction` (forward/backward viscous, Coulomb level and offset of a one-DOF model).
"""

from .final import final_intervals
from .forces import ResidualForce, residual_force
from .friction import FrictionReading, friction_reading
from .results import Check, EffectScore, LoopResult, LoopStep
from .scoring import refine_gap, score_effects
from .screen import screen_effects
from .search import close_the_loop, close_the_loop_with, loop_effects

__all__ = [
    "Check",
    "EffectScore",
    "FrictionReading",
    "LoopResult",
    "LoopStep",
    "ResidualForce",
    "close_the_loop",
    "close_the_loop_with",
    "final_intervals",
    "friction_reading",
    "loop_effects",
    "refine_gap",
    "residual_force",
    "score_effects",
    "screen_effects",
]
