"""The frequency route's automatic order: the modes that stay put across orders (docs/method.md §3, §11).

The largest gap of the singular values follows the modes that dominate the response; on a measured
structure with many modes, nonlinear distortion and residual dynamics outside the band there may
be no gap at all (the F-16 ground vibration test: order 2 picked for about ten resonances). A
structural dynamicist reads a stabilisation diagram instead: poles of the subspace models of
increasing order, and the physical modes are those whose frequency, damping and shape stay put
from one order to the next, while poles that fit noise or distortion wander.

:func:`stable_modes` scans the orders of one subspace decomposition (cheap: one eigenvalue problem
per order) and keeps the clusters of poles inside the band that are stable between consecutive
orders (frequency within ``FREQUENCY_TOLERANCE``, damping ratio within ``DAMPING_TOLERANCE``
relative, mode shapes at the outputs with a modal assurance criterion above ``MAC_MIN``) in at
least half of the orders from the first one where they are stable, and in at least
``MIN_STABLE_ORDERS`` of them. The model order is then twice the number of those modes plus
``RESIDUAL_PAIRS`` pairs for the dynamics outside the band (rigid-body-like modes below it,
flexible ones above: the refinement places them where the lines need them).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["StableMode", "stable_modes", "stabilised_order"]

FREQUENCY_TOLERANCE = 0.01
"""Largest relative frequency change of a stable pole between consecutive orders."""
DAMPING_TOLERANCE = 0.3
"""Largest relative damping-ratio change (plus 0.002 absolute) of a stable pole between consecutive orders."""
MAC_MIN = 0.9
"""Smallest modal assurance criterion of a stable pole's output shape between consecutive orders."""
MAX_DAMPING = 0.3
"""Poles more damped than this are not taken for modes (residual dynamics, noise)."""
MIN_STABLE_ORDERS = 3
"""A mode is stable at this many orders at least."""
RESIDUAL_PAIRS = 2
"""Pole pairs added to the stable modes' for the dynamics outside the band."""


@dataclass(frozen=True)
class StableMode:
    """A mode of the stabilisation diagram.

    Attributes
    ----------
    frequency_hz, damping_ratio : float
        Medians over the orders where it is stable.
    first_order : int
        Lowest order at which it is stable.
    fraction : float
        Share of the scanned orders from ``first_order`` on where it is stable.
    """

    frequency_hz: float
    damping_ratio: float
    first_order: int
    fraction: float


def stable_modes(poles_at: Callable[[int], tuple[np.ndarray, np.ndarray]], orders: Sequence[int],
                 band_hz) -> tuple[StableMode, ...]:
    """Modes of the band that stay put across the model orders (module notes).

    Parameters
    ----------
    poles_at : callable
        ``order -> (poles, shapes)``: the continuous poles [rad/s] of the model of that order and
        their output shapes ``C v`` (columns).
    orders : sequence of int
        Increasing orders scanned.
    band_hz : (float, float)
        Modes are looked for inside this band.

    Returns
    -------
    tuple of StableMode
        In increasing frequency.
    """
    orders = list(orders)
    stable: list[tuple[int, float, float]] = []
    previous: list[tuple[float, float, np.ndarray]] | None = None
    for n in orders:
        lam, shapes = poles_at(n)
        upper = lam.imag > 0
        lam, shapes = lam[upper], shapes[:, upper]
        freq, zeta = np.abs(lam) / (2 * np.pi), -lam.real / np.maximum(np.abs(lam), 1e-300)
        inside = (freq >= band_hz[0]) & (freq <= band_hz[1]) & (zeta > 0) & (zeta < MAX_DAMPING)
        current = [(float(freq[i]), float(zeta[i]), shapes[:, i]) for i in np.flatnonzero(inside)]
        if previous is not None:
            stable += [(n, f, z) for f, z, v in current if any(_same(f, z, v, *p) for p in previous)]
        previous = current
    stable.sort(key=lambda item: item[1])
    clusters: list[list[tuple[int, float, float]]] = []
    for item in stable:  # neighbours in frequency within the tolerance: one mode
        if clusters and item[1] - clusters[-1][-1][1] < FREQUENCY_TOLERANCE * item[1]:
            clusters[-1].append(item)
        else:
            clusters.append([item])
    out = []
    for cluster in clusters:
        at = sorted({n for n, _, _ in cluster})
        span = sum(1 for n in orders if n >= at[0])
        fraction = len(at) / span
        if len(at) >= MIN_STABLE_ORDERS and fraction >= 0.5:
            out.append(StableMode(float(np.median([f for _, f, _ in cluster])),
                                  float(np.median([z for _, _, z in cluster])), at[0], fraction))
    return tuple(out)


def _same(f, z, v, fp, zp, vp) -> bool:
    """Two poles of consecutive orders are one mode (frequency, damping, shape; module notes)."""
    if abs(f - fp) >= FREQUENCY_TOLERANCE * f or abs(z - zp) >= DAMPING_TOLERANCE * max(z, zp) + 0.002:
        return False
    norm = float(np.vdot(v, v).real * np.vdot(vp, vp).real)
    return norm > 0 and float(np.abs(np.vdot(v, vp)) ** 2) / norm > MAC_MIN


def stabilised_order(modes: Sequence[StableMode], limit: int) -> int:
    """Twice the number of stable modes plus the residual pairs (module notes), within ``[2, limit]``.

    Parameters
    ----------
    modes : sequence of StableMode
    limit : int
        Largest order allowed.

    Returns
    -------
    int
        An even order (``limit`` rounded down to even when it binds).
    """
    order = 2 * (len(modes) + RESIDUAL_PAIRS)
    return max(2, min(order, limit - limit % 2))
