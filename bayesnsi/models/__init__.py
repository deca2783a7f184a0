"""Candidate nonlinear terms and models: the lowest layer (numpy only)."""

from .dictionary import (
    EFFECT_TYPES,
    SMOOTH_FRICTION,
    Effect,
    clearance_expression,
    default_gaps,
    default_widths,
    effect_dictionary,
    smooth_friction_effect,
)
from .expressions import Expression, parse_expression
from .terms import CandidateModel, Term, nonlinear_force

__all__ = [
    "Expression",
    "parse_expression",
    "Term",
    "CandidateModel",
    "nonlinear_force",
    "EFFECT_TYPES",
    "Effect",
    "effect_dictionary",
    "clearance_expression",
    "default_gaps",
    "SMOOTH_FRICTION",
    "default_widths",
    "smooth_friction_effect",
]
