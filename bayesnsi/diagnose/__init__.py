"""Closing the loop on measured data (SPEC section 7): find what the model lacks, add it."""

from .forces import ResidualForce, residual_force
from .screen import screen_effects
from .search import LOOP_EVIDENCE_DEFAULTS, LoopResult, LoopStep, close_the_loop, refine_gap, score_effects

__all__ = [
    "LOOP_EVIDENCE_DEFAULTS",
    "LoopResult",
    "LoopStep",
    "ResidualForce",
    "close_the_loop",
    "refine_gap",
    "residual_force",
    "score_effects",
    "screen_effects",
]
