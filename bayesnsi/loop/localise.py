"""Where is the nonlinearity? A data-only localisation for periodic records (docs/method.md §7, §11).

On a periodic multisine test the output at the lines the force leaves empty is nonlinear
distortion (plus noise). Measured in the *relative* motion across a candidate location (the
motion of one sensor for an element to ground), its level over that motion's level at the excited
lines is largest where the nonlinear force acts: a joint between two sensors distorts their
relative motion most, while each sensor alone also carries the linear response of every mode.
The lines that hold the distortion (:func:`detection_lines`) are those the force leaves empty
between the excited ones (a random-odd multisine) and above the excited band up to three times
its top (the harmonics of the nonlinear forces; a multisine that excites every line of its band
has only these), where the record holds anything (a response integrated over a band is zero
outside it: integrate over a wider band than the one fitted to see the harmonics). The powers are
those of the displacement (the quantity the model is fitted in), noise subtracted, and divided by
the power at the excited lines: a ratio, free of units. Measured on the F-16 ground vibration test
(docs/measurements.md): the wing-payload pair 2-3 leads every other location 36-82x on the full
multisines (levels 1, 3, 5) and 20-76x on the random-odd ones (in relative acceleration, lines
weighted by ω⁴, only 4-14x and 1.1-2.1x: the harmonics far above the modes weigh most there, where
other sources distort too); on the simulated ground vibration test (:func:`bayesnsi.simulate.gvt_records`)
the joint pair leads at every level (``benchmarks/gvt_loop.py``). This costs one FFT per
location, no identification.

:func:`screen_effects_periodic` orders the loop's screen by it: effects at the location with the
most distortion first; within a location the frequency-domain screen
(:func:`bayesnsi.loop.screen.screen_effects`) orders them, and even effects (``x²``: they
distort only even lines) go last where the record has unexcited even lines and they hold
nothing but noise (a random-odd multisine then tells that the nonlinearity is odd).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.ndimage

from ..exceptions import BayesNSIError
from ..nsi import period_spectra
from ..signals import Signals
from .screen import screen_effects

if TYPE_CHECKING:
    from ..models.dictionary import Effect

__all__ = ["DETECTION_REACH", "DetectionLines", "EVEN_NOISE_RATIO", "DISTORTION_NOISE_RATIO", "detection_lines",
           "location_distortion", "screen_effects_periodic"]

EVEN_NOISE_RATIO = 2.0
"""Even lines whose median power is below this multiple of their noise level hold no even distortion."""


def _location_motion(signals: Signals, location) -> np.ndarray | None:
    """Displacement at a one-DOF location, or the relative displacement of a two-DOF one (None: unmeasured)."""
    columns = {dof: k for k, dof in enumerate(signals.output_dofs)}
    if not location or any(dof not in columns for dof in location):
        return None
    x = np.asarray(signals.displacement, dtype=float)
    motion = x[:, columns[location[0]]].copy()
    for dof in location[1:2]:
        motion -= x[:, columns[dof]]
    return motion


def location_distortion(signals: Signals, locations) -> dict[tuple[int, ...], tuple[float, float]]:
    """Distortion level of the motion at each location, from the data alone (module notes).

    Parameters
    ----------
    signals : Signals
        A periodic record (``signals.period``) with one force.
    locations : iterable of tuple of int
        One DOF (its displacement) or two (their relative displacement ``x_j - x_k``).

    Returns
    -------
    dict
        ``location -> (distortion, even)``: ``distortion`` the power at the detection lines
        (:func:`detection_lines`) above its noise level over the power at the excited lines, both
        in displacement (a ratio: the units do not matter), NaN where the detection lines' power is on average below
        ``DISTORTION_NOISE_RATIO`` times their noise level (nothing to localise: the screen alone
        orders the effects then); ``even`` the median power at the unexcited even lines
        between the excited ones over their noise level (about 1: no even distortion). NaN for an
        unmeasured location or where there is no such line.

    Raises
    ------
    BayesNSIError
        Without a period or with several forces.
    """
    locations = [tuple(int(d) for d in loc) for loc in dict.fromkeys(tuple(loc) for loc in locations)]
    found = {loc: _location_motion(signals, loc) for loc in locations}
    motions = {loc: motion for loc, motion in found.items() if motion is not None}
    measured = [loc for loc in locations if loc in motions]
    out = {loc: (float("nan"), float("nan")) for loc in locations}
    if not measured:
        return out
    if getattr(signals, "period", None) is None or signals.force.shape[1] != 1:
        raise BayesNSIError("the data-only localisation needs a periodic record with one force")
    stacked = Signals(
        force=signals.force, displacement=np.column_stack([motions[loc] for loc in measured]), fs=signals.fs,
        input_dofs=signals.input_dofs, output_dofs=tuple(range(1, len(measured) + 1)), period=signals.period,
        realisations=getattr(signals, "realisations", 1),
    )
    lines = detection_lines(stacked)
    with np.errstate(all="ignore"):
        signal = np.sum(lines.power[lines.excited], axis=0)
        distortion = np.full(len(measured), np.nan)
        if lines.detection.any():
            power, noise = lines.power[lines.detection], lines.noise[lines.detection]
            excess = np.sum(power - noise, axis=0)
            # a line's noise level from a few periods scatters as χ²: smoothed over neighbouring lines for the test
            smoothed = scipy.ndimage.median_filter(lines.noise, size=(_SMOOTH_LINES, 1), mode="nearest")
            seen = np.mean(power / smoothed[lines.detection], axis=0) >= DISTORTION_NOISE_RATIO
            distortion[seen] = np.maximum(excess[seen], 0.0) / signal[seen]
        even = (np.median(lines.power[lines.even] / lines.noise[lines.even], axis=0) if lines.even.any()
                else np.full(len(measured), np.nan))
    for k, loc in enumerate(measured):
        out[loc] = (float(distortion[k]), float(even[k]))
    return out


@dataclass(frozen=True)
class DetectionLines:
    """Lines of a periodic record and what they hold (:func:`detection_lines`).

    Attributes
    ----------
    freqs_hz : ndarray, shape (K,)
    power, noise : ndarray, shape (K, l)
        Mean over realisations of the period-averaged displacement power and of its noise variance.
    excited : ndarray of bool, shape (K,)
        Lines the force excites in every realisation.
    detection : ndarray of bool, shape (K,)
        Lines excited in no realisation from the lowest excited line up to ``DETECTION_REACH`` times
        the highest, where the record holds more than its numerical floor (a response integrated
        over a band is zero outside it).
    even : ndarray of bool, shape (K,)
        The detection lines of even index between the lowest and the highest excited line.
    n_periods : int
        Periods averaged per realisation.
    """

    freqs_hz: np.ndarray
    power: np.ndarray
    noise: np.ndarray
    excited: np.ndarray
    detection: np.ndarray
    even: np.ndarray
    n_periods: int


DISTORTION_NOISE_RATIO = 2.0
"""Detection lines whose power is on average below this multiple of their (smoothed) noise level show no
distortion: nothing to localise there (noise alone gives about 1.4, the running median's bias included)."""
_SMOOTH_LINES = 9
DETECTION_REACH = 3.0
"""Detection lines reach this multiple of the highest excited frequency (odd harmonics up to the third)."""
_FLOOR = 1e-6
"""A line whose noise level is below this fraction of the median noise at the excited lines holds nothing."""
_POWER_FLOOR = 1e-12
"""Nor does a line whose power is below this fraction of the median power at the excited lines (rounding
errors outside a band the response was integrated over)."""


def detection_lines(signals: Signals) -> DetectionLines:
    """Excited and detection lines of a periodic record and the output power on them (module notes).

    On a random-odd multisine the detection lines are the odd and even lines left out between the
    excited ones; on a multisine exciting every line of its band (the F-16's "full" multisine) only
    the lines above the band hold the distortion (the harmonics of the nonlinear forces); both
    count.

    Parameters
    ----------
    signals : Signals
        A periodic record with one force (several realisations: the same lines in each).

    Returns
    -------
    DetectionLines
    """
    spectra = [period_spectra(one) for one in signals.realisation_records()]
    first = spectra[0]
    power = np.mean([np.abs(s.response) ** 2 for s in spectra], axis=0)
    noise = np.mean([s.response_var for s in spectra], axis=0)
    excited_all = np.logical_and.reduce([s.excited for s in spectra])
    excited_any = np.logical_or.reduce([s.excited for s in spectra])
    k = np.arange(len(first.freqs_hz))
    detection = np.zeros_like(excited_all)
    even = np.zeros_like(excited_all)
    if excited_all.any():
        low, high = np.flatnonzero(excited_all)[[0, -1]]
        reach = first.freqs_hz <= DETECTION_REACH * first.freqs_hz[high]
        with np.errstate(all="ignore"):
            content = (np.all(noise > _FLOOR * np.median(noise[excited_all], axis=0), axis=1)
                       & np.all(power > _POWER_FLOOR * np.median(power[excited_all], axis=0), axis=1)
                       & np.all(np.isfinite(noise), axis=1))
        detection = (k >= low) & reach & ~excited_any & content & (k < len(k) - 1)
        even = detection & (k <= high) & (k % 2 == 0)
    return DetectionLines(first.freqs_hz, power, noise, excited_all, detection, even, first.n_periods)


def _is_even(term, signals: Signals, velocity_method: str) -> bool:
    """True when the term's force is the same at (-x, -v) as at (x, v) on the data (e.g. x²)."""
    x, v = signals.state_arrays(velocity_method=velocity_method)
    with np.errstate(all="ignore"):
        plus, minus = term.evaluate(x, v), term.evaluate(-x, -v)
    if not (np.all(np.isfinite(plus)) and np.all(np.isfinite(minus))):
        return False
    return bool(np.std(plus) > 0 and np.allclose(plus, minus, rtol=1e-9, atol=1e-12 * np.max(np.abs(plus))))


def screen_effects_periodic(
    signals: Signals, candidate, effects, *, max_frequency_hz: float | None = None, velocity_method: str = "fourth",
) -> list[tuple[Effect, float, float]]:
    """Order effects by the data-only distortion level of their location, then by the screen (module notes).

    Parameters
    ----------
    signals : Signals
        A periodic record with one force.
    candidate : CandidateModel
        The current model (its terms are not proposed again).
    effects : list of Effect
    max_frequency_hz : float, optional
        Passed to :func:`bayesnsi.loop.screen.screen_effects`, which scores each effect.
    velocity_method : str
        Differentiator when the signals carry no velocities.

    Returns
    -------
    list of (Effect, float, float)
        Best first: each effect with its screen score (the log-likelihood ratio of
        :func:`bayesnsi.loop.screen.screen_effects`; ``-inf`` for an effect that cannot be
        built) and its location's distortion level (:func:`location_distortion`). Ordered by that
        level, then by the score; even effects go after every other where the record has
        unexcited even lines and they hold only noise.

    Raises
    ------
    BayesNSIError
        When the record is not periodic with one force.
    """
    if getattr(signals, "period", None) is None or signals.force.shape[1] != 1:
        raise BayesNSIError("the periodic screen needs a periodic record with one force")
    within: list[tuple[Effect, float]] = screen_effects(signals, candidate, effects, max_frequency_hz=max_frequency_hz,
                                                     velocity_method=velocity_method)
    levels = location_distortion(signals, [e.location for e, _ in within])
    ranked = []
    for effect, score in within:
        level, even = levels[tuple(effect.location)]
        level = level if np.isfinite(level) else -np.inf
        kept = np.isfinite(score) and not (np.isfinite(even) and even < EVEN_NOISE_RATIO
                                           and _is_even(effect.term, signals, velocity_method))
        ranked.append(((kept, level, score), effect, level))
    ranked.sort(key=lambda item: item[0], reverse=True)  # stable: ties keep the screen's order
    return [(effect, float(key[2]), float(level)) for key, effect, level in ranked]
