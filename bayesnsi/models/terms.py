"""Nonlinear terms with a location, and candidate models (docs/method.md §1 and 9)."""

from __future__ import annotations

import functools
import itertools
import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..exceptions import ConfigError, ExpressionError
from .expressions import Expression, parse_expression

__all__ = ["Term", "CandidateModel", "nonlinear_force"]

_HIDDEN_CATEGORIES = ("Cc", "Cf", "Cs", "Zl", "Zp")  # control, format (bidi), surrogate, line/paragraph separators
_PROBE_SEED = 20_251_124
_PROBE_POINTS = 48
_COLLINEAR_RTOL = 1e-9


def _normalise_location(at) -> tuple[int, ...]:
    loc: tuple[int, ...]
    if isinstance(at, (int, np.integer)) and not isinstance(at, bool):
        loc = (int(at),)
    elif isinstance(at, (list, tuple)) and len(at) in (1, 2) and all(
        isinstance(a, (int, np.integer)) and not isinstance(a, bool) for a in at
    ):
        loc = tuple(int(a) for a in at)
    else:
        raise ExpressionError(
            f"term location must be a DOF number (at = 3) or a pair of DOFs (at = [3, 4]), got {at!r}"
        )
    if any(a < 1 for a in loc):
        raise ExpressionError(f"DOFs are numbered from 1, got at = {at!r}")
    if len(loc) == 2 and loc[0] == loc[1]:
        raise ExpressionError(f"an element between DOFs needs two different DOFs, got at = {at!r}")
    return loc


@dataclass(frozen=True)
class Term:
    """One nonlinear term λ l n(x, v) of the equation of motion (paper Eq. 6).

    Parameters
    ----------
    expr : str or Expression
        The basis function n(x, v), e.g. ``"v1*abs(v1)"``.
    at : int or (int, int)
        Location: DOF ``k`` (l = e_k, grounded) or DOFs ``(j, k)`` (l = e_j - e_k, an element
        between two DOFs: force +n at j, -n at k).
    """

    expr: Expression
    at: tuple[int, ...]

    def __init__(self, expr, at):
        object.__setattr__(self, "expr", expr if isinstance(expr, Expression) else parse_expression(expr))
        object.__setattr__(self, "at", _normalise_location(at))

    @property
    def name(self) -> str:
        """Readable identifier, e.g. ``v1*abs(v1)@1`` or ``(x3-x4)**3@3-4``."""
        return f"{self.expr.canonical}@{'-'.join(map(str, self.at))}"

    @property
    def at_value(self):
        """Location as written in a config: an int, or a list of two ints."""
        return self.at[0] if len(self.at) == 1 else list(self.at)

    @property
    def dofs(self) -> tuple[int, ...]:
        """All DOFs the term reads or acts on."""
        return tuple(sorted(set(self.expr.dofs) | set(self.at)))

    def location_vector(self, n_dofs: int) -> np.ndarray:
        """Location vector l (paper Eq. 6), shape (n_dofs,)."""
        if max(self.at) > n_dofs:
            raise ExpressionError(f"term {self.name} acts on DOF {max(self.at)} but the model has {n_dofs} DOFs")
        loc = np.zeros(n_dofs)
        loc[self.at[0] - 1] = 1.0
        if len(self.at) == 2:
            loc[self.at[1] - 1] = -1.0
        return loc

    def evaluate(self, x, v, periodic: bool = False) -> np.ndarray:
        """Basis function n(x, v); see :meth:`Expression.evaluate` for the DOF-major layout and ``periodic``."""
        return self.expr.evaluate(x, v, periodic)

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class CandidateModel:
    """A named set of nonlinear terms with a prior probability (docs/method.md §9).

    Parameters
    ----------
    name : str
        Label used in tables and results.json.
    terms : sequence of Term
        The nonlinear terms; may be empty (a linear model).
    prior : float
        Prior model probability P(μ) (unnormalised; normalised over the candidate set).
    coefficient_priors : mapping or None
        Optional per-term prior scale of the coefficient (used by the evidence).
    """

    name: str
    terms: tuple[Term, ...]
    prior: float = 1.0
    coefficient_prior_scales: tuple[float | None, ...] = field(default=())

    def __post_init__(self):
        object.__setattr__(self, "terms", tuple(self.terms))
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError("every candidate needs a non-empty name")
        hidden = next((c for c in self.name if unicodedata.category(c) in _HIDDEN_CATEGORIES), None)
        if hidden is not None:
            raise ConfigError(
                f"candidate name {self.name!r} holds the control character U+{ord(hidden):04X}; "
                "use printable characters only"
            )
        if not all(isinstance(t, Term) for t in self.terms):
            raise ConfigError(f"candidate {self.name!r}: terms must be Term objects")
        names = [t.name for t in self.terms]
        if len(set(names)) != len(names):
            raise ConfigError(f"candidate {self.name!r} repeats a term: {names}")
        pair = _collinear_pair(self.terms)
        if pair is not None:
            raise ConfigError(
                f"candidate {self.name!r}: terms {pair[0].name} and {pair[1].name} are the same function up to a "
                "constant factor at the same location, so their coefficients cannot be separated; keep one of them"
            )
        combination = _dependent_combination(self.terms)
        if combination is not None:
            raise ConfigError(
                f"candidate {self.name!r}: its terms are linearly dependent, "
                f"{_combination_text(self.terms, combination)} = 0 for every motion, so one force could be split "
                "between them in any proportion; drop one of them"
            )
        if not (np.isfinite(self.prior) and self.prior > 0):
            raise ConfigError(f"candidate {self.name!r}: prior must be a positive number, got {self.prior!r}")
        scales = tuple(self.coefficient_prior_scales) or (None,) * len(self.terms)
        if len(scales) != len(self.terms):
            raise ConfigError(f"candidate {self.name!r}: one prior scale per term expected")
        object.__setattr__(self, "coefficient_prior_scales", scales)

    @classmethod
    def from_terms(cls, name: str, terms: Iterable, prior: float = 1.0) -> CandidateModel:
        """Build from ``(expr, at)`` pairs or Term objects."""
        built = tuple(t if isinstance(t, Term) else Term(*t) for t in terms)
        return cls(name=name, terms=built, prior=prior)

    @property
    def n_terms(self) -> int:
        """Number of nonlinear terms q."""
        return len(self.terms)

    def with_term(self, term: Term, name: str | None = None) -> CandidateModel:
        """A new candidate with one more term (used when closing the loop)."""
        return CandidateModel(
            name=name or f"{self.name} + {term.name}",
            terms=self.terms + (term,),
            prior=self.prior,
            coefficient_prior_scales=self.coefficient_prior_scales + (None,),
        )


def _collinear_pair(terms: Sequence[Term]) -> tuple[Term, Term] | None:
    """Two terms with proportional forces (same location up to sign, proportional basis functions).

    The basis functions are compared on a fixed random probe of displacements and velocities
    whose magnitudes span 1e-6 to 1e3 with both signs, so terms that differ only for small or
    only for large arguments are told apart; proportional means equal zeros and a constant
    ratio elsewhere (relative tolerance 1e-9, rounding only).
    """
    groups: dict[tuple[int, ...], list[Term]] = {}
    for term in terms:
        groups.setdefault(tuple(sorted(term.at)), []).append(term)
    for group in groups.values():
        for a, b in itertools.combinations(group, 2):
            if _proportional(_probe_values(a.expr), _probe_values(b.expr)):
                return a, b
    return None


def _dependent_combination(terms: Sequence[Term]) -> np.ndarray | None:
    """Weights ``c`` (largest 1) with ``sum_i c_i l_i n_i(x, v) = 0`` on the probe; None for independent forces.

    The forces ``l_i n_i`` of the terms (location vector times basis function, :meth:`Term.location_vector`)
    are evaluated on the probe of :func:`_collinear_pair`, each point scaled to its largest value so
    that small and large arguments count alike; a singular value below ``_COLLINEAR_RTOL`` of the
    largest (rounding only) is a linear dependence, e.g. ``x1**3``, ``v1*abs(v1)`` and their sum.
    """
    if len(terms) < 2:
        return None
    dofs = sorted({dof for term in terms for dof in term.at})
    columns = []
    for term in terms:
        values = _probe_values(term.expr)
        force = np.zeros((len(dofs), values.size))
        force[dofs.index(term.at[0])] = values
        if len(term.at) == 2:
            force[dofs.index(term.at[1])] -= values
        columns.append(force.ravel())
    matrix = np.stack(columns, axis=1)
    if not np.all(np.isfinite(matrix)):
        return None
    scale = np.max(np.abs(matrix), axis=0)  # first to the column's peak: a steep force (a stiff Bouc-Wen branch)
    if np.any(scale == 0):                  # would overflow the sum of squares
        return None
    norms = scale * np.linalg.norm(matrix / scale, axis=0)
    matrix = matrix / norms
    peak = np.max(np.abs(matrix), axis=1, keepdims=True)
    matrix = matrix / np.where(peak > 0, peak, 1.0)
    _, singular, vt = np.linalg.svd(matrix, full_matrices=False)
    if singular[-1] > _COLLINEAR_RTOL * singular[0]:
        return None
    weights = vt[-1] / norms
    weights = weights / weights[np.argmax(np.abs(weights))]
    weights[np.abs(weights) < 1e-9] = 0.0
    return weights


def _combination_text(terms: Sequence[Term], weights: np.ndarray) -> str:
    """``1·(x1**3 at 1) + 1·(v1*abs(v1) at 1) - 1·(...)``: the dependence, in the terms' own words."""
    parts = []
    for term, weight in zip(terms, weights):
        if weight == 0:
            continue
        sign = "-" if weight < 0 else "+"
        parts.append(f"{sign} {abs(weight):.3g}·({term.name})")
    text = " ".join(parts)
    return text[2:] if text.startswith("+ ") else text


@functools.lru_cache(maxsize=4096)
def _probe_values(expr: Expression) -> np.ndarray:
    x = {dof - 1: _probe_state(dof, 0) for dof in expr.displacement_dofs}
    v = {dof - 1: _probe_state(dof, 1) for dof in expr.velocity_dofs}
    values = np.broadcast_to(expr.evaluate(x, v), (_PROBE_POINTS,)).copy()  # a constant gives a scalar
    values.flags.writeable = False
    return values


@functools.lru_cache(maxsize=1024)
def _probe_state(dof: int, kind: int) -> np.ndarray:
    rng = np.random.default_rng([_PROBE_SEED, dof, kind])
    return rng.choice([-1.0, 1.0], _PROBE_POINTS) * 10.0 ** rng.uniform(-6.0, 3.0, _PROBE_POINTS)


def _proportional(a: np.ndarray, b: np.ndarray) -> bool:
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return False
    nonzero = a != 0
    if not nonzero.any() or np.any(nonzero != (b != 0)):
        return False
    ratio = a[nonzero] / b[nonzero]
    return bool(np.all(np.abs(ratio - ratio[0]) <= _COLLINEAR_RTOL * np.abs(ratio[0])))


def nonlinear_force(terms: Sequence[Term], coefficients, x, v, n_dofs: int) -> np.ndarray:
    """Total nonlinear restoring force Σ λ_i l_i n_i(x, v) (paper Eq. 6).

    Parameters
    ----------
    terms : sequence of Term
    coefficients : array_like, shape (q,)
    x, v : ndarray, shape (n_dofs, ...)
        DOF-major displacements and velocities.
    n_dofs : int

    Returns
    -------
    ndarray, shape (n_dofs, ...)
    """
    force = np.zeros((n_dofs,) + np.shape(x)[1:])
    for term, coef in zip(terms, np.atleast_1d(coefficients)):
        value = coef * term.evaluate(x, v)
        force[term.at[0] - 1] += value
        if len(term.at) == 2:
            force[term.at[1] - 1] -= value
    return force
