"""The width of a smoothed friction ``tanh(v/ε)`` searched off the dictionary's grid (docs/method.md §7).

The dictionary offers two widths per location, a quarter and half the spread of the velocity the
friction acts on (:func:`bayesnsi.models.default_widths`); a joint's friction may be much sharper
(the simulated ground vibration test: ``tanh(v/0.002)``, 0.11 std of the relative velocity at 1 N).
The width changes what the friction predicts where the joint nearly sticks, which the record's
own fit barely sees and another level shows. So the best grid width of a location whose friction
ranks among the effects the loop examines is searched in ``log ε`` by the evidence, like a
clearance's gap (:func:`bayesnsi.loop.scoring.refine_gap`) and a Bouc-Wen element's shape
(:mod:`bayesnsi.loop.shapes`): the two neighbours at the current step are scored, the better that
beats the current width becomes it, the step halves when neither does, until
:data:`WIDTH_RESOLUTION`; never below the smallest grid width nor above the largest. Sharper,
``tanh`` turns into ``sign(v)``, its ε → 0 limit, which the dictionary holds at the same location (as
a clearance's gap stays above the grid's smallest, where it turns into a linear spring): with half the
smallest as the bound the loop suite took tanh(v2/0.026-0.033), sharper than the grid, in place of
sign(v2) in 3 of its 40 Coulomb and two-missing runs (docs/measurements.md); unbounded, also the free
body and the look-alike pair. Wider, ``tanh`` took the place of ``v|v|`` on the quadratic-damping case.
On the simulated ground vibration test at 1 N the evidence of ``tanh((v7-v8)/ε)`` peaks near
ε = 0.003 (0.002 true; benchmarks/gvt_loop.py), below the grid: the search keeps 0.00455.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..models import Effect
from ..models.dictionary import smooth_friction_effect
from .results import EffectScore

__all__ = ["WIDTH_RESOLUTION", "WIDTH_STEP", "search_width"]

WIDTH_STEP = 0.5
"""First step of the width search in ``log2 ε`` (a factor √2; the grid's two widths lie a factor 2 apart)."""
WIDTH_RESOLUTION = 1.0 / 8
"""The search stops once its step in ``log2 ε`` is below this (a factor 1.09)."""


def search_width(entry: EffectScore, score: Callable[[Effect], EffectScore], grid=(), budget: int = 12) -> EffectScore:
    """The best width of ``entry``'s friction found from its grid width (see module notes).

    Parameters
    ----------
    entry : EffectScore
        A scored ``tanh(v/ε)`` effect (any other effect is returned as it is).
    score : callable
        Identifies and scores the model enlarged by one effect.
    grid : sequence of float
        The dictionary's widths at ``entry``'s location: the search stays between the smallest and the
        largest (outside, a width lets ``tanh`` stand in for ``sign(v)`` or ``v|v|``).
    budget : int
        Most identifications.

    Returns
    -------
    EffectScore
        The best entry found (``entry`` itself when no other width beats it).
    """
    eps, at = entry.effect.eps, entry.effect.location
    if eps is None or not np.isfinite(entry.log_evidence):
        return entry
    widths = [float(w) for w in grid] or [float(eps)]
    low, high = min(widths), max(widths)
    best, step, tried = entry, WIDTH_STEP, {float(eps)}
    while budget > 0 and step >= WIDTH_RESOLUTION:
        moved = False
        for sign in (-1.0, 1.0):
            width = float(f"{best.effect.eps * 2.0 ** (sign * step):.3g}")
            if width in tried or not low <= width <= high or budget <= 0:
                continue
            tried.add(width)
            budget -= 1
            neighbour = score(smooth_friction_effect(at, width))
            if neighbour.log_evidence > best.log_evidence:
                best, moved = neighbour, True
                break
        if not moved:
            step /= 2
    return best
