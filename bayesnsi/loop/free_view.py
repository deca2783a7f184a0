"""The loop in one view: a start that is not a free body, on data that hold one.

The loop compares each re-identified effect with the current model by their log-evidences; the
free-body view policy (:mod:`bayesnsi.checks.free_view`) makes them comparable. A start without
friction can identify as a grounded oscillator (the friction and a position loop look like a spring)
while the start plus ``sign(v)`` identifies as a free body. :func:`free_body_start` scores the first
search from the start as the loop would; when an effect identifies as a free body and the start does
not, the start is identified again in that view, the loop's settings keep the spring (every later
model is scored on the force) and the first search runs again in that view.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from ..checks.free_view import free_body_view
from ..exceptions import BayesNSIError, BayesNSIWarning
from ..nsi import identify, is_free_body
from .scoring import rank_effects
from .state import LoopContext

__all__ = ["free_body_start"]


def free_body_start(context: LoopContext, start, screen_band: float):
    """The loop's context and start in the free-body view when the data call for it.

    Parameters
    ----------
    context : LoopContext
        The loop's context (``nsi.virtual_stiffness == "auto"`` is the only case that can change).
    start : NSIResult
        The starting model as identified.
    screen_band : float
        The screen's top frequency as a multiple of the start's highest natural frequency.

    Returns
    -------
    (LoopContext, NSIResult, list of EffectScore or None)
        The context (with the virtual spring fixed when switched), the start, and the scores of
        the first search when they stay valid (no switch), else None.
    """
    if context.nsi.virtual_stiffness != "auto" or is_free_body(start):
        return context, start, None
    scored = rank_effects(context, start.candidate, [])
    nsi = free_body_view(context.nsi, (s.result for s in scored))
    if nsi is None:
        return context, start, scored
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            again = identify(context.signals, start.candidate, nsi)
    except (BayesNSIError, np.linalg.LinAlgError):
        return context, start, scored
    if not is_free_body(again):
        return context, start, scored
    top_hz = max([m.frequency_hz for m in again.modes] or [again.band_hz[1]])
    screen_hz = None if context.screen_hz is None else screen_band * top_hz
    return replace(context, nsi=nsi, screen_hz=screen_hz), again, None
