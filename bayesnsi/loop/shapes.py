"""The Bouc-Wen elements of the loop's dictionary: which grid points a search scores, and their shape search.

A Bouc-Wen element (docs/method.md §12) comes in nine grid shapes per location
(:func:`bayesnsi.models.default_shapes`): variants of one effect. The screen's places go to the
effects without memory, and the best-ranked grid point of each of a few locations (theirs, then the
next in screen order: :data:`SHAPE_LOCATIONS`) is re-identified besides them (:func:`screened_shapes`;
the next ones when it fails to identify, :func:`shape_fallbacks`);
a grid point that beats the model and every effect without memory has its shape searched off the
grid (:func:`search_shape`), unless its quality index fails the loop's check by a wide margin
(:data:`SEARCH_INDEX_FACTOR`): off the grid the right element's index falls from at most 0.92 (the grid
points about the truth of the simulated hysteresis case, 1-5 % noise) to 0.01-0.07, while the grid points
the F-16's loop searched (ground and interface locations, model-form error; 1.3-4.1) kept failing
it after the search (1.1-9.3) at 30 identifications each (docs/measurements.md, "Bouc-Wen hysteresis in
the loop"). The functions take the scorer of one effect (an :class:`EffectScore`
of the enlarged model) from :mod:`bayesnsi.loop.scoring`, which calls them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..models import BoucWen, Effect
from ..models.dictionary import hysteresis_effect, hysteretic_shape
from .results import EffectScore

__all__ = ["SEARCH_INDEX_FACTOR", "SHAPE_LOCATIONS", "SHAPE_MIN_GAIN", "SHAPE_RESOLUTION", "SHAPE_STEPS",
           "displacement_spread", "screened_shapes", "search_shape", "shape_fallbacks"]

SHAPE_STEPS = (0.5, 0.55)
"""First steps of the Bouc-Wen shape search in ``asinh((β + γ) σ)`` and ``log((β - γ) σ)`` (σ: std of the
displacement the element acts on); about half the default grid's spacing."""
SHAPE_RESOLUTION = 1.0 / 16
"""The search stops once its steps are this fraction of :data:`SHAPE_STEPS`."""
SHAPE_LOCATIONS = 6
"""Most locations whose best Bouc-Wen grid point a screen keeps (:func:`screened_shapes`): every location of a
three-sensor record (the F-16's, the simulated ground vibration test's), 6 of the 78 of twelve sensors."""
SHAPE_MIN_GAIN = 0.01
"""On the frequency route, the least gain of a move of the search as a fraction of the grid point's log Bayes factor
over the model without it (:func:`bayesnsi.loop.scoring.refine_shape`)."""
SEARCH_INDEX_FACTOR = 4.0
"""A grid point whose quality index is at least this multiple of ``LoopOptions.max_imag_ratio`` and fails the
loop's check has no shape search (module notes)."""


def displacement_spread(signals, effect: Effect) -> float:
    """Std σ of the displacement a Bouc-Wen effect acts on, on ``signals`` (NaN for another effect).

    Parameters
    ----------
    signals : Signals
    effect : Effect

    Returns
    -------
    float
    """
    expr = effect.term.expr
    if expr.memory_argument is None:
        return float("nan")
    rows, _ = signals.state_rows(list(expr.displacement_dofs), [])
    return float(np.std(expr.memory_argument(rows, {})))


def search_shape(entry: EffectScore, score: Callable[[Effect, EffectScore], EffectScore], sigma: float,
                 budget: int = 30, confirm: Callable[[Effect], EffectScore] | None = None,
                 rounded_revisits: bool = True, min_gain: float = 0.0) -> EffectScore:
    """Refine the shape of a Bouc-Wen effect off the grid by its Laplace log-evidence (docs/method.md §12).

    A compass search over the loading and unloading branches, in ``asinh((β + γ) σ)`` and
    ``log((β - γ) σ)``: the four neighbours at the current steps are scored, the best that beats the
    current point becomes it, and the steps halve when none does, until they reach
    :data:`SHAPE_RESOLUTION` of :data:`SHAPE_STEPS` or ``budget`` identifications were made. Only
    shapes with memory are tried (:func:`bayesnsi.models.dictionary.hysteretic_shape`: β > 0 and at
    least |γ|/2, a loading branch that hardens no faster than ``HARDENING_LIMIT``); a shape whose
    identification fails (e.g. its underlying linear model comes out unstable: a hysteresis that
    dissipates too much leaves the linear damping negative) scores −inf and is passed over. n is kept.

    Each shape tried is scored by ``score(effect, near)``, which may identify it from ``near``, the best entry so far
    (a neighbouring shape: its model is a start that needs a few steps of the refinement, where a full
    identification runs the subspace step and refines from two starts). The shape the search ends on is then
    identified in full by ``confirm``, and kept when that beats ``entry``: the entry returned is the one a full
    identification gives, the search's scores only chose the shape.

    The shapes are written with 3 significant digits (:func:`bayesnsi.models.dictionary.hysteresis_effect`),
    so the search can reach a shape it tried back by another path, differing from the first visit by the
    rounding only (another term name). With ``rounded_revisits`` False such a shape (within a quarter of the
    finest steps of a shape tried, on both axes) is not scored again: where ``score`` starts from the best
    entry so far, its second score differs from its first by the start only (on the F-16's level 3, 15 of the
    146 shapes scored; docs/measurements.md, "Bouc-Wen hysteresis in the loop").

    Parameters
    ----------
    entry : EffectScore
        A scored Bouc-Wen effect (any other effect is returned as it is).
    score : callable
        ``score(effect, near) -> EffectScore``: the candidate with ``effect`` added, identified (it may start
        from ``near.result``) and scored.
    sigma : float
        Std of the displacement the element acts on (:func:`displacement_spread`).
    budget : int
        Most identifications of the search (``confirm``'s is not counted).
    confirm : callable, optional
        ``confirm(effect) -> EffectScore``: the full identification of the shape found; None takes the
        search's score as it is.
    rounded_revisits : bool
        Score a shape the search reaches back up to the rounding (True), or pass it over (False).
    min_gain : float
        Least gain in log-evidence over the best entry so far for a neighbour to become it (0: any gain).

    Returns
    -------
    EffectScore
        The best entry found (``entry`` itself when nothing beats it).
    """
    shape, at = entry.effect.shape, entry.effect.location
    if shape is None or shape.unloading <= 0 or not sigma > 0:
        return entry
    best, names, seen = entry, {entry.term.name}, [_coordinates(shape, sigma)]
    steps = list(SHAPE_STEPS)
    while budget > 0 and steps[0] >= SHAPE_RESOLUTION * SHAPE_STEPS[0]:
        current = best.effect.shape
        assert current is not None
        point = (np.arcsinh(current.loading * sigma), np.log(current.unloading * sigma))
        moved = False
        for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1)):
            moved_point = list(point)
            moved_point[axis] += sign * steps[axis]
            neighbour_shape = BoucWen.from_branches(np.sinh(moved_point[0]) / sigma, np.exp(moved_point[1]) / sigma,
                                                current.n)
            if not hysteretic_shape(neighbour_shape, sigma) or budget <= 0:
                continue
            neighbour_effect = hysteresis_effect(at, neighbour_shape)
            assert neighbour_effect.shape is not None
            tried = _coordinates(neighbour_effect.shape, sigma)
            if neighbour_effect.term.name in names or (not rounded_revisits and _visited(tried, seen)):
                continue
            names.add(neighbour_effect.term.name)
            seen.append(tried)
            budget -= 1
            neighbour = score(neighbour_effect, best)
            if neighbour.log_evidence > best.log_evidence + min_gain:
                best, moved = neighbour, True
        if not moved:
            steps = [step / 2 for step in steps]
    if best is entry or confirm is None:
        return best
    confirmed = confirm(best.effect)
    return confirmed if confirmed.log_evidence > entry.log_evidence else entry


def _coordinates(shape: BoucWen, sigma: float) -> tuple[float, float]:
    """The search's coordinates of ``shape``: ``(asinh((β + γ) σ), log((β - γ) σ))``."""
    return float(np.arcsinh(shape.loading * sigma)), float(np.log(shape.unloading * sigma))


def _visited(point: tuple[float, float], seen: list[tuple[float, float]]) -> bool:
    """Whether ``point`` lies within a quarter of the search's finest steps of a point in ``seen``, on both axes."""
    finest = [SHAPE_RESOLUTION * step for step in SHAPE_STEPS]
    return any(all(abs(p - q) < 0.25 * f for p, q, f in zip(point, other, finest)) for other in seen)


def screened_shapes(ordered: list[Effect], count: int, locations: int = SHAPE_LOCATIONS) -> list[Effect]:
    """The effects a screen keeps: its ``count`` best without memory, the best Bouc-Wen grid point of a few locations.

    The locations are those of the kept effects without memory first, then the next in screen order (the
    periodic screen orders by the data-only localisation, :func:`bayesnsi.loop.localise.screen_effects_periodic`),
    at most ``locations`` of them: with every sensor pair a location, one grid point per location would cost
    n(n + 1)/2 identifications per loop step (78 for 12 sensors).

    Parameters
    ----------
    ordered : list of Effect
        The effects in screen order, best first.
    count : int
        The screen's places (``LoopOptions.screen``).
    locations : int
        Most locations with a Bouc-Wen grid point (:data:`SHAPE_LOCATIONS`).

    Returns
    -------
    list of Effect
    """
    kept = [e for e in ordered if e.shape is None][:count]
    chosen = list(dict.fromkeys([e.location for e in kept] + [e.location for e in ordered if e.shape is not None]))
    allowed = set(chosen[:locations])
    located: set = set()
    for e in ordered:
        if e.shape is not None and e.location in allowed and e.location not in located:
            located.add(e.location)
            kept.append(e)
    return kept


def shape_fallbacks(scored: list[EffectScore], rest: list[EffectScore], score: Callable[[Effect], EffectScore],
                    tries: int = 3) -> tuple[list[EffectScore], list[EffectScore]]:
    """At a location whose screened Bouc-Wen grid point failed, the next grid points there, until one identifies.

    Parameters
    ----------
    scored : list of EffectScore
        The re-identified effects.
    rest : list of EffectScore
        The screened-out ones, in screen order.
    score : callable
        ``score(effect) -> EffectScore``: the candidate with ``effect`` added, identified and scored.
    tries : int
        Most grid points tried per location.

    Returns
    -------
    (list of EffectScore, list of EffectScore)
        ``scored`` (best first) and ``rest`` with the entries moved from the one to the other.
    """
    finite = {e.effect.location for e in scored if e.effect.shape is not None and np.isfinite(e.log_evidence)}
    failed = {e.effect.location for e in scored if e.effect.shape is not None} - finite
    if not failed:
        return scored, rest
    scored, rest = list(scored), list(rest)
    for location in sorted(failed):
        for waiting in [r for r in rest if r.effect.shape is not None and r.effect.location == location][:tries]:
            rest.remove(waiting)
            entry = score(waiting.effect)
            scored.append(replace(entry, screen_rank=waiting.screen_rank, screen_score=waiting.screen_score,
                                  screen_view=waiting.screen_view, screen_location=waiting.screen_location))
            if np.isfinite(entry.log_evidence):
                break
    scored.sort(key=lambda item: item.log_evidence, reverse=True)
    return scored, rest
