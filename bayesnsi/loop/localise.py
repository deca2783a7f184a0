"""Where is the nonlinearity? A data-only localisation for periodic records (docs/method.md §7, §11).

On a periodic multisine test the output at the lines the force leaves empty is nonlinear
distortion (plus noise). Measured in the *relative* motion across a candidate location (the
motion of one sensor for an element to ground), its level over that motion's level at the excited
lines is largest where the nonlinear force acts: a joint between two sensors distorts their
relative motion most, while each sensor alone also carries the linear response of every mode.
On the simulated ground vibration test (:func:`bayesnsi.simulate.gvt_records`) the joint pair led
every other location by 3.4-8x at all three levels (``benchmarks/gvt_loop.py``). This costs one
FFT per location, no identification.

:func:`screen_effects_periodic` orders the loop's screen by it: effects at the location with the
most distortion first; within a location the frequency-domain screen
(:func:`bayesnsi.loop.screen.screen_effects`) orders them, and even effects (``x²``: they
distort only even lines) go last where the even lines hold nothing but noise (a random-odd
multisine then tells that the nonlinearity is odd).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..exceptions import BayesNSIError
from ..nsi import best_linear_approximation
from ..signals import Signals
from .screen import screen_effects

if TYPE_CHECKING:
    from ..models.dictionary import Effect

__all__ = ["EVEN_NOISE_RATIO", "location_distortion", "screen_effects_periodic"]

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
    """Distortion level of the motion at each location, from the data alone.

    Parameters
    ----------
    signals : Signals
        A periodic record (``signals.period``) with one force.
    locations : iterable of tuple of int
        One DOF (its displacement) or two (their relative displacement ``x_j - x_k``).

    Returns
    -------
    dict
        ``location -> (odd, even)``: ``odd`` the median output power at the unexcited odd lines
        over the median power at the excited lines (distortion-to-signal ratio), ``even`` the
        median power at the unexcited even lines over their noise level (about 1: no even
        distortion). NaN for an unmeasured location or where there is no such line.

    Raises
    ------
    BayesNSIError
        Without a period, with several forces or too few periods (:func:`bayesnsi.nsi.best_linear_approximation`).
    """
    locations = [tuple(int(d) for d in loc) for loc in dict.fromkeys(tuple(loc) for loc in locations)]
    found = {loc: _location_motion(signals, loc) for loc in locations}
    motions = {loc: motion for loc, motion in found.items() if motion is not None}
    measured = [loc for loc in locations if loc in motions]
    out = {loc: (float("nan"), float("nan")) for loc in locations}
    if not measured:
        return out
    stacked = Signals(
        force=signals.force, displacement=np.column_stack([motions[loc] for loc in measured]), fs=signals.fs,
        input_dofs=signals.input_dofs, output_dofs=tuple(range(1, len(measured) + 1)), period=signals.period,
        realisations=getattr(signals, "realisations", 1),
    )
    with np.errstate(all="ignore"):
        bla = best_linear_approximation([stacked])
        excited = np.median(np.abs(bla.frf) ** 2, axis=0) * bla.force_level**2
        odd = np.median(bla.odd_power, axis=0) / excited if len(bla.odd_hz) else np.full(len(measured), np.nan)
        even = bla.unexcited_ratio()["even"]
    for k, loc in enumerate(measured):
        out[loc] = (float(odd[k]), float(even[k]))
    return out


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
) -> list[tuple[Effect, float]]:
    """Order effects by the data-only distortion level of their location (module notes).

    Parameters
    ----------
    signals : Signals
        A periodic record with one force.
    candidate : CandidateModel
        The current model (its terms are not proposed again).
    effects : list of Effect
    max_frequency_hz : float, optional
        Passed to :func:`bayesnsi.loop.screen.screen_effects`, which orders effects within a location.
    velocity_method : str
        Differentiator when the signals carry no velocities.

    Returns
    -------
    list of (Effect, float)
        Best first; the score is the location's distortion-to-signal ratio (minus 1 for even
        effects where the even lines hold only noise), ``-inf`` for an effect that cannot be built.

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
    for rank, (effect, score) in enumerate(within):
        odd, even = levels[tuple(effect.location)]
        level = odd if np.isfinite(odd) else -np.inf
        if not np.isfinite(score):
            level = -np.inf
        elif not even >= EVEN_NOISE_RATIO and _is_even(effect.term, signals, velocity_method):
            level -= 1.0  # after every odd effect: the data show no even distortion
        ranked.append((level, -rank, effect))
    ranked.sort(key=lambda item: (item[0], item[1]), reverse=True)
    return [(effect, float(level)) for level, _, effect in ranked]
