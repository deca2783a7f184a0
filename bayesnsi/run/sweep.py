"""Large candidate databases: every subset of a dictionary of terms.

>>> from bayesnsi.run import dictionary_candidates
>>> models = dictionary_candidates([1, 2], types=["x^3", "v|v|"], max_terms=2)
>>> len(models), models[0].name, models[1].name
(22, 'linear', 'x1**3@1')
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

from ..exceptions import ConfigError
from ..models import CandidateModel, Term
from ..models.dictionary import DEFAULT_EFFECT_TYPES, EFFECT_TYPES, effect_dictionary

__all__ = ["MAX_CANDIDATES", "count_subsets", "dictionary_candidates", "subset_candidates"]

MAX_CANDIDATES = 100_000
"""Largest candidate database built in one call (a guard against a mistyped ``max_terms``)."""


def count_subsets(n_terms: int, max_terms: int, min_terms: int = 0) -> int:
    """Number of subsets of ``n_terms`` terms with ``min_terms`` to ``max_terms`` elements.

    Parameters
    ----------
    n_terms : int
        Size of the dictionary.
    max_terms, min_terms : int
        Largest and smallest subset size; sizes above ``n_terms`` are not counted.

    Returns
    -------
    int
        ``sum(comb(n_terms, k) for k in min_terms..min(max_terms, n_terms))``: the number of
        candidates :func:`subset_candidates` builds for these arguments.
    """
    return sum(math.comb(n_terms, size) for size in range(min_terms, min(max_terms, n_terms) + 1))


def subset_candidates(
    terms: Iterable[Term | tuple],
    max_terms: int = 2,
    min_terms: int = 0,
    prior: float = 1.0,
) -> tuple[CandidateModel, ...]:
    """Every subset of ``terms`` with ``min_terms`` to ``max_terms`` terms, as candidates.

    Parameters
    ----------
    terms : iterable of Term or (expr, at)
        The dictionary; repeated terms are an error.
    max_terms, min_terms : int
        Subset sizes (0 gives the linear model, named ``"linear"``).
    prior : float
        Prior weight of every candidate.

    Returns
    -------
    tuple of CandidateModel
        By size, then in dictionary order; each named by its terms joined with ``" + "``.

    Raises
    ------
    ConfigError
        For an empty dictionary, repeated terms, bad sizes, or more than
        :data:`MAX_CANDIDATES` candidates.
    """
    dictionary: list[Term] = [t if isinstance(t, Term) else Term(*t) for t in terms]
    if not dictionary:
        raise ConfigError("the term dictionary is empty; give at least one term to build candidates from")
    names = [t.name for t in dictionary]
    if len(set(names)) != len(names):
        raise ConfigError(f"the term dictionary repeats a term ({sorted({n for n in names if names.count(n) > 1})})")
    _check_sizes(min_terms, max_terms, len(dictionary))
    models = []
    for size in range(min_terms, min(max_terms, len(dictionary)) + 1):
        for subset in itertools.combinations(dictionary, size):
            name = " + ".join(t.name for t in subset) or "linear"
            models.append(CandidateModel(name=name, terms=subset, prior=prior))
    return tuple(models)


def dictionary_candidates(
    dofs: Sequence[int],
    types: Iterable[str] = DEFAULT_EFFECT_TYPES,
    max_terms: int = 2,
    min_terms: int = 0,
    pairs: Sequence[tuple[int, int]] | None = None,
) -> tuple[CandidateModel, ...]:
    """Every subset of the effect dictionary (:func:`~bayesnsi.models.effect_dictionary`).

    Parameters
    ----------
    dofs : sequence of int
        Measured DOFs; effects sit at each and between neighbours (or ``pairs``).
    types : iterable of str
        Effect types (keys of :data:`~bayesnsi.models.dictionary.EFFECT_TYPES`).
    max_terms, min_terms : int
        Subset sizes.
    pairs : sequence of (j, k), optional
        Element locations (default: consecutive measured DOFs).

    Returns
    -------
    tuple of CandidateModel
        E.g. two DOFs, the seven effect types and ``max_terms = 2``: 21 terms, 232 candidates.
    """
    types = list(types)
    unknown = sorted(set(types) - set(EFFECT_TYPES))
    if unknown:
        raise ConfigError(f"unknown effect type(s) {unknown}; choose from {list(EFFECT_TYPES)}")
    if not list(dofs):
        raise ConfigError("no DOFs given for the effect dictionary; pass the measured DOFs, e.g. [1, 2]")
    terms = [effect.term for effect in effect_dictionary(dofs, types, pairs=pairs)]
    return subset_candidates(terms, max_terms=max_terms, min_terms=min_terms)


def _check_sizes(min_terms, max_terms, n_terms) -> None:
    for name, value in (("min_terms", min_terms), ("max_terms", max_terms)):
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ConfigError(f"{name} must be a non-negative integer, got {value!r}")
    if min_terms > max_terms:
        raise ConfigError(f"min_terms = {min_terms} exceeds max_terms = {max_terms}; swap them")
    count = count_subsets(n_terms, max_terms, min_terms)
    if count > MAX_CANDIDATES:
        raise ConfigError(
            f"{n_terms} terms with up to {max_terms} per candidate give {count} candidates, more than "
            f"{MAX_CANDIDATES}; lower max_terms or use fewer effect types"
        )
