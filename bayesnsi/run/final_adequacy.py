"""Adequacy and widened intervals of a model outside a selection: the loop's final model (issue 15).

``select`` checks every candidate (:func:`bayesnsi.run.adequacy.model_checks`) and widens the
intervals of an inadequate one by its residual-to-noise ratio (:func:`~bayesnsi.run.adequacy.widen_inadequate`);
``bayesnsi diagnose`` gives its final model the same treatment with :func:`widen_final`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .adequacy import model_checks, widen_inadequate

__all__ = ["widen_final"]


@dataclass(frozen=True)
class _Model:
    """A model as :func:`model_checks` and :func:`widen_inadequate` read a candidate's outcome."""

    name: str
    result: Any
    intervals: Any


def widen_final(result, intervals, signals, *, max_noise_ratio: float = 1.3, max_imag_ratio: float = 0.3,
                validation=()):
    """The intervals of a model outside a selection (the loop's final model), widened as ``select`` widens.

    Parameters
    ----------
    result : NSIResult
        The model, e.g. ``LoopResult.final``.
    intervals : Intervals
        Its intervals (:func:`bayesnsi.diagnose.final_intervals`).
    signals : Signals
        The estimation data.
    max_noise_ratio, max_imag_ratio : float
        As :func:`model_checks`.
    validation : tuple of SegmentError
        The model's errors on the validation segments (:func:`bayesnsi.validation.validate`), for the
        check's ``validation_nrmse``.

    Returns
    -------
    intervals : Intervals
        Widened by the residual-to-noise ratio when the model is inadequate (:func:`widen_inadequate`),
        else as given.
    check : ModelCheck or None
        The model's adequacy figures (None when its residual cannot be computed).
    """
    model = _Model(name="final", result=result, intervals=intervals)
    checks = model_checks([model], signals, {"final": tuple(validation)} if validation else None,
                          max_noise_ratio=max_noise_ratio, max_imag_ratio=max_imag_ratio)
    (widened,), checks = widen_inadequate([model], checks, signals)
    return widened.intervals, checks.get("final")
