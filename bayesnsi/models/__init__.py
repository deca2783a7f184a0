"""Candidate nonlinear terms and models: the lowest layer (numpy only)."""

from .dictionary import (
    EFFECT_TYPES,
    HYSTERESIS,
    SMOOTH_FRICTION,
    Effect,
    clearance_expression,
    default_gaps,
    default_shapes,
    default_widths,
    effect_dictionary,
    hysteresis_effect,
    smooth_friction_effect,
)
from .expressions import Expression, parse_expression
from .hysteresis import BoucWen, HysteresisReading, boucwen_path, boucwen_periodic, hysteresis_reading
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
    "HYSTERESIS",
    "default_shapes",
    "hysteresis_effect",
    "BoucWen",
    "HysteresisReading",
    "boucwen_path",
    "boucwen_periodic",
    "hysteresis_reading",
]
