"""Closing the loop on measured data (docs/method.md §7): find what the model lacks, add it.

Modules: :mod:`~bayesnsi.loop.search` (the loop), :mod:`~bayesnsi.loop.scoring` (Laplace
evidence of each effect, the screen, clearance gaps), :mod:`~bayesnsi.loop.guards` (the one
acceptance rule: Bayes factor, quality index judged against the model's misfit
(:mod:`~bayesnsi.loop.quality`), record halves (:mod:`~bayesnsi.loop.halves`), separability,
dissipation), :mod:`~bayesnsi.loop.moves` (prune, look ahead, re-examine),
:mod:`~bayesnsi.loop.state` (the loop's context and state), :mod:`~bayesnsi.loop.results`,
:mod:`~bayesnsi.loop.screen`, :mod:`~bayesnsi.loop.forces`, :mod:`~bayesnsi.loop.friction`
(forward/backward viscous, Coulomb level and offset of a one-DOF model).
"""

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
    "friction_reading",
    "loop_effects",
    "refine_gap",
    "residual_force",
    "score_effects",
    "screen_effects",
]
