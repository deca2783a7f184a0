"""The loop in one view: a start that is not a free body, on data that hold one.

The loop compares each re-identified effect with the current model by their log-evidences. A free
body is identified with a virtual spring and scored on the force it predicts (docs/method.md
§11); whether a model is one is decided per identification (``[nsi] virtual_stiffness =
"auto"``). A start without friction can identify as a grounded oscillator (the friction and a
position loop look like a spring), while the start plus ``sign(v)`` identifies as a free body: the
Bayes factor then compared a force residual with a displacement residual. On a carriage in a
position loop (M 20 kg, Fv 30 N s/m, Coulomb 8 N) the loop from the linear model gave sign(v1)
a log Bayes factor of -265 251 (log Z -2 438 on the force against +262 813 on the displacement),
never examined it, and added a clearance the carriage does not have.

:func:`free_body_start` scores the first search from the start as the loop would; when an effect
identifies as a free body and the start does not, the start is identified again with that
effect's virtual spring, the loop's settings keep the spring (every later model is scored on the
force) and the first search runs again in that view.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

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
    free = next((s.result for s in scored if s.result is not None and is_free_body(s.result)), None)
    if free is None:
        return context, start, scored
    nsi = context.nsi.replace(virtual_stiffness=free.virtual_stiffness)
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
