"""Closing the loop on measured data (SPEC section 7): find what the model lacks, add it."""

from .search import LOOP_EVIDENCE_DEFAULTS, LoopResult, LoopStep, close_the_loop, refine_gap, score_effects

__all__ = ["LOOP_EVIDENCE_DEFAULTS", "LoopResult", "LoopStep", "close_the_loop", "refine_gap", "score_effects"]
