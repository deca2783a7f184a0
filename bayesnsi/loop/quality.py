"""The loop's quality-index check, judged against the model's misfit (docs/method.md §7).

The numbers and the rule are :mod:`bayesnsi.checks.misfit`'s (shared with the model checks of ``select``): the
index passes below ``max_imag_ratio``; above it, it decides alone when the enlarged model is (nearly) adequate
(misfit ratio κ at most ``misfit_bound``, ``EvidenceOptions.max_band_ratio``), and otherwise fails only when
the frequency dependence of λ(ω) is resolved against the misfit (memory resolution M > 1). Here it becomes a
:class:`~bayesnsi.loop.results.Check` whose text gives κ and M.
"""

from __future__ import annotations

import math

import numpy as np

from ..checks.misfit import MisfitReading, index_judgement, misfit_reading
from .results import Check

__all__ = ["MisfitReading", "misfit_reading", "quality_check"]


def quality_check(imag_ratio: float, max_imag_ratio: float, misfit_bound: float,
                  reading: MisfitReading | None) -> tuple[Check, bool]:
    """The quality-index check of an effect, judged against its model's misfit (module notes).

    Parameters
    ----------
    imag_ratio : float
        The effect's quality index |Im λ|/|Re λ|.
    max_imag_ratio : float
        ``LoopOptions.max_imag_ratio``.
    misfit_bound : float
        ``EvidenceOptions.max_band_ratio``: up to this misfit ratio the model is (nearly) adequate and the index
        decides alone.
    reading : MisfitReading or None
        :func:`bayesnsi.checks.misfit.misfit_reading` of the enlarged model; None (or NaN fields) judges the
        index alone.

    Returns
    -------
    (Check, bool)
        The check (value: the index; limit: ``max_imag_ratio``) and whether it passed only because the index
        is not resolved against the misfit (``LoopStep.index_unresolved``).
    """
    ratio = float(imag_ratio)
    passed, unresolved = index_judgement(ratio, max_imag_ratio, misfit_bound, reading)
    if ratio < max_imag_ratio:
        return Check("quality index", ratio, max_imag_ratio, True,
                     f"quality index |Im|/|Re| = {ratio:.2f} < {max_imag_ratio}"), False
    kappa, resolution = (math.nan, math.nan) if reading is None else (reading.misfit_ratio, reading.resolution)
    head = f"quality index |Im|/|Re| = {ratio:.2f} >= {max_imag_ratio}"
    if not (np.isfinite(kappa) and np.isfinite(resolution)):
        return Check("quality index", ratio, max_imag_ratio, False, head), False
    if kappa <= misfit_bound:
        return Check("quality index", ratio, max_imag_ratio, False,
                     f"{head} (the model's residual is {kappa:.3g}x the noise, within "
                     f"max_band_ratio {misfit_bound:g}: the index decides)"), False
    where = (f"the model's residual is {kappa:.3g}x the noise, and where the effect carries power the imaginary part "
             f"of λ(ω) moves the outputs by {resolution:.2f}x what that misfit leaves undetermined")
    if not passed:
        return Check("quality index", ratio, max_imag_ratio, False, f"{head}, resolved against the misfit: {where} "
                     "(> 1)"), False
    return Check("quality index", ratio, max_imag_ratio, True,
                 f"{head} but not resolved against the misfit: {where} (<= 1), so the index cannot judge the "
                 "effect here"), unresolved
