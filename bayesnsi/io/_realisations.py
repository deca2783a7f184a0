"""A window of several realisations of a periodic test (``[data] realisations``, also per ``[[validation]]``).

A ground vibration test ships R realisations (new multisine phases) of P periods each, often one
after the other in one file, each starting with transient periods. The estimation window is cut
into R equal parts; each part loses its ``transient_periods`` and is processed (integrated line by
line, decimated) and checked for periodicity on its own; the parts are then joined into one
:class:`~bayesnsi.signals.Signals` with ``realisations = R``, whose frequency route stacks the
lines of all realisations (docs/method.md §11).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..exceptions import ConfigError

__all__ = ["Split", "joined", "split_parts"]


class Split(NamedTuple):
    """How a window holds realisations: ``n_parts`` equal parts, ``drop`` transient periods each, ``key`` names it."""

    n_parts: int
    drop: int
    key: str


def split_parts(period: int | None, path: Path, start: int, stop: int, split: Split | None) -> list[tuple[int, int]]:
    """The file windows ``[a, b)`` of the steady periods of each realisation of ``[start, stop)``.

    Parameters
    ----------
    period : int or None
        Samples per period (``[data] period``, file samples).
    path : Path
        The file (named in messages).
    start, stop : int
        The window [file samples].
    split : Split or None
        Realisations and transient periods of the window (``[data] realisations`` and
        ``transient_periods`` for the estimation window, the same keys of a ``[[validation]]``
        segment); None: one part.

    Returns
    -------
    list of (int, int)
        One window per realisation, in order.

    Raises
    ------
    ConfigError
        When the window does not split into ``count`` equal parts of whole periods, or a part keeps
        fewer than two periods after its transient ones.
    """
    if split is None or period is None or (split.n_parts == 1 and split.drop == 0):
        return [(start, stop)]
    count, drop = split.n_parts, split.drop
    length = (stop - start) // count
    if (stop - start) % count or length % period:
        raise ConfigError(
            f"{path}: {split.key} [{start}, {stop}) of {stop - start} samples does not split into "
            f"realisations = {count} equal parts of whole periods of {period} samples; give a window of {count} x "
            f"(a whole number of periods) x {period} samples that starts where the first realisation starts"
        )
    if length // period - drop < 2:
        raise ConfigError(
            f"{path}: each of the {count} realisation(s) of {split.key} holds {length // period} period(s) of "
            f"{period} samples, {length // period - drop} after transient_periods = {drop}; the noise needs at least "
            "two steady periods per realisation: lower transient_periods or realisations, or widen the window"
        )
    return [(start + r * length + drop * period, start + (r + 1) * length) for r in range(count)]


def joined(windows: list[tuple]) -> tuple:
    """Processed windows ``(force, displacement, velocity or None)`` one after the other.

    Parameters
    ----------
    windows : list of tuple
        Each ``(force, displacement, velocity)`` of one realisation.

    Returns
    -------
    tuple
        ``(force, displacement, velocity)`` concatenated in time.
    """
    if len(windows) == 1:
        return windows[0]
    velocity = None if windows[0][2] is None else np.concatenate([w[2] for w in windows])
    return np.concatenate([w[0] for w in windows]), np.concatenate([w[1] for w in windows]), velocity
