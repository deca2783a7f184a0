"""The classical fourth-order Runge-Kutta step as linear maps, and its error on linear modes.

:func:`bayesnsi.simulate.simulate_response` marches with these maps (the stages and the update
of ``ż = A z + u`` as matrices acting on the state and the four stage inputs), in the fixed
order of operations of :mod:`bayesnsi.simulate._fixed_order`.
"""

from __future__ import annotations

import numpy as np

from ._fixed_order import product

__all__ = ["rk4_maps", "rk4_modal_error"]


def rk4_modal_error(frequencies_hz, damping_ratios, step: float):
    """Frequency and damping errors RK4 makes on linear modes.

    Parameters
    ----------
    frequencies_hz : array_like
        Natural frequencies [Hz].
    damping_ratios : array_like
        Damping ratios (broadcast against ``frequencies_hz``).
    step : float
        RK4 step h [s].

    Returns
    -------
    relative_frequency_error : ndarray
        (f_RK4 - f) / f, where f_RK4 is the natural frequency of the continuous pole
        equivalent to the RK4 amplification factor R(hs) = 1 + hs + (hs)²/2 + (hs)³/6 +
        (hs)⁴/24, i.e. ``log(R(hs)) / h``. About -(ωh)⁴/120 for light damping.
    damping_ratio_error : ndarray
        ζ_RK4 - ζ, of order (ωh)⁵/144 (positive, i.e. numerical damping, for an undamped mode).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    zeta = np.asarray(damping_ratios, dtype=float)
    w = 2 * np.pi * f
    s = w * (-zeta + 1j * np.sqrt(1 - zeta**2 + 0j))
    hs = step * s
    R = 1 + hs + hs**2 / 2 + hs**3 / 6 + hs**4 / 24
    s_eq = np.log(R) / step
    w_eq = np.abs(s_eq)
    return w_eq / w - 1.0, -s_eq.real / w_eq - zeta


def rk4_maps(A: np.ndarray, h: float):
    """RK4 stages and update as linear maps of (z, u1, u2, u3, u4), with k_s = A z_s + u_s."""
    size = A.shape[0]
    eye, zero = np.eye(size), np.zeros((size, size))

    def lin(zpart, upart):
        return [zpart, list(upart)]

    def add(a, b, cb=1.0):
        return [a[0] + cb * b[0], [ua + cb * ub for ua, ub in zip(a[1], b[1])]]

    def slope(state, s):  # k_s = A z_s + u_s
        upart = [product(A, u) for u in state[1]]
        upart[s] = upart[s] + eye
        return [product(A, state[0]), upart]

    z = lin(eye, [zero] * 4)
    stages, ks = [z], []
    for s, frac in enumerate((0.5, 0.5, 1.0)):
        ks.append(slope(stages[-1], s))
        stages.append(add(z, ks[-1], frac * h))
    ks.append(slope(stages[-1], 3))
    final = z
    for weight, k in zip((1.0, 2.0, 2.0, 1.0), ks):
        final = add(final, k, weight * h / 6.0)
    return [st[0] for st in stages], [st[1] for st in stages], final[0], final[1]
