"""Candidate nonlinear terms and models: the lowest layer (numpy only)."""

from .expressions import Expression, parse_expression
from .terms import CandidateModel, Term, nonlinear_force

__all__ = ["Expression", "parse_expression", "Term", "CandidateModel", "nonlinear_force"]
