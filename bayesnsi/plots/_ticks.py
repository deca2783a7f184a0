"""Ticks of the report's figures: plain-text labels, and only the ticks a reader sees.

Matplotlib's log axes label decades in mathtext (``$10^{-2}$``, whose parser is built on first
use) and carry eight minor ticks per decade, a decade beyond each end included; its linear
locators add a tick beyond each end. Every tick is a handful of artists made, laid out and measured
at each draw: with the mathtext parse, most of the cost of a report's figures (docs/measurements.md,
"What the report costs"). The same reading costs less with labels in plain Unicode text (``10⁻²``)
and ticks inside the view only.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.ticker import FuncFormatter, Locator, MaxNLocator, NullLocator

__all__ = ["decade_ticks", "frequency_ticks", "in_view", "power_of_ten"]

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def power_of_ten(value: float, _position=None) -> str:
    """``"10⁻²"``: a decade in plain text (superscript digits; no mathtext).

    Parameters
    ----------
    value : float
        A positive power of ten.

    Returns
    -------
    str
    """
    return "10" + str(round(math.log10(value))).translate(_SUPERSCRIPT)


def _plain(value: float, _position=None) -> str:
    return f"{value:g}"


class _LogSteps(Locator):
    """Ticks of a log axis inside its view: decades (every ``stride``-th, at most ``most`` of them), or
    1-2-5 steps when the view spans too few decades for that; ``minor``: the 2 and 5 between decades."""

    def __init__(self, most: int = 6, steps: bool = True, minor: bool = False):
        self.most, self.steps, self.minor = most, steps, minor

    def __call__(self):
        low, high = self.axis.get_view_interval()
        return self.tick_values(low, high)

    def tick_values(self, vmin, vmax):
        low, high = sorted((float(vmin), float(vmax)))
        if not (low > 0 and np.isfinite(high)):
            return np.zeros(0)
        first, last = math.floor(math.log10(low)), math.ceil(math.log10(high))
        decades = 10.0 ** np.arange(first, last + 1)
        spread = decades[(decades >= low * (1 - 1e-9)) & (decades <= high * (1 + 1e-9))]
        by_steps = self.steps and len(spread) <= 3  # few decades: 1, 2, 5 labelled
        if self.minor:
            values = np.zeros(0) if by_steps else np.outer(decades, (2.0, 5.0)).ravel()
        elif by_steps:
            values = np.outer(decades, (1.0, 2.0, 5.0)).ravel()
        else:
            stride = max(1, math.ceil(len(spread) / self.most))
            values = decades[(np.arange(first, last + 1) % stride) == 0]
        return values[(values >= low * (1 - 1e-9)) & (values <= high * (1 + 1e-9))]


def decade_ticks(axis, most: int = 5) -> None:
    """Label the decades of a log axis as ``10ⁿ`` (every other one when more than ``most``); no minor ticks.

    Call after the axis scale is set (setting a scale resets the ticks).

    Parameters
    ----------
    axis : matplotlib.axis.Axis
    most : int
        At most this many labelled decades.
    """
    axis.set_major_locator(_LogSteps(most, steps=False))
    axis.set_major_formatter(FuncFormatter(power_of_ten))
    axis.set_minor_locator(NullLocator())


def frequency_ticks(axis) -> None:
    """Ticks of a log frequency axis as plain numbers: 1, 2, 5 per decade over up to three decades, else the
    decades labelled and 2, 5 unlabelled between them.

    Call after the axis scale is set (setting a scale resets the ticks).

    Parameters
    ----------
    axis : matplotlib.axis.Axis
    """
    axis.set_major_locator(_LogSteps(8))
    axis.set_major_formatter(FuncFormatter(_plain))
    axis.set_minor_locator(_LogSteps(minor=True))



class _InView(Locator):
    """A locator's ticks inside the view only (matplotlib's own add one beyond each end, made and laid out
    at each draw though never shown)."""

    def __init__(self, base: Locator):
        self.base = base

    def set_axis(self, axis):
        super().set_axis(axis)
        self.base.set_axis(axis)

    def __call__(self):
        low, high = sorted(self.axis.get_view_interval())
        return self._inside(self.base(), low, high)

    def tick_values(self, vmin, vmax):
        low, high = sorted((vmin, vmax))
        return self._inside(self.base.tick_values(vmin, vmax), low, high)

    @staticmethod
    def _inside(values, low, high):
        values = np.asarray(values, dtype=float)
        slack = 1e-9 * (high - low)
        return values[(values >= low - slack) & (values <= high + slack)]


def in_view(axis, bins: int) -> None:
    """Tick a linear axis at round steps (at most ``bins`` intervals), inside its view only.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
    bins : int
        :class:`matplotlib.ticker.MaxNLocator`'s ``nbins``.
    """
    axis.set_major_locator(_InView(MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10])))
