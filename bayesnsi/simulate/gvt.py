"""A simulated ground vibration test: many modes, few sensors, a nonlinear joint.

Built like a real test rather than a textbook case: a 12-DOF free-free chain on a soft
suspension (the rigid-body mode at 0.49 Hz lies below the band), nine flexible modes in the
excited band 1.5-15 Hz and three more around it, one shaker at DOF 2 and three accelerometers
(DOFs 2, 7, 8), and a joint between the two sensor locations 7 and 8 with smoothed friction
``F_f tanh((v7 - v8)/ε)`` and a hardening contact ``k3 (x7 - x8)³``. The force is a random-odd
multisine (new phases per realisation, the same lines) repeated over several periods after
leading transient periods, at three or more amplitude levels; the accelerometers carry 1-2 %
noise. The joint's expressions are not declared anywhere a config would see them: they are the
effect a user's loop should find.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError
from ..models import Term
from .integrate import add_output_noise, simulate_response
from .multisine import multisine, multisine_lines
from .structures import modal_damping

__all__ = ["GVT_BAND_HZ", "GVT_JOINT", "GVT_SENSORS", "GVT_SHAKER", "GVTRecord", "gvt_records", "gvt_structure"]

GVT_SENSORS = (2, 7, 8)
"""DOFs of the three accelerometers."""
GVT_SHAKER = 2
"""DOF of the shaker (a driving-point measurement with sensor 2)."""
GVT_JOINT = (7, 8)
"""The nonlinear joint acts between these two sensor DOFs."""
GVT_BAND_HZ = (1.5, 15.0)
"""Excited band [Hz]."""

_MASSES = (2.0, 1.5, 1.8, 1.2, 1.6, 1.4, 1.0, 1.1, 1.7, 1.3, 1.9, 2.2)  # kg
_SPRINGS = (4200.0, 3600.0, 4000.0, 3300.0, 3900.0, 3500.0, 2600.0, 3700.0, 3400.0, 4100.0, 3800.0)  # N/m
_SUSPENSION = 90.0  # N/m at each end
_DAMPING = 0.015  # modal damping ratio of the flexible modes
_SUSPENSION_DAMPING = 0.10  # of the suspension (rigid-body) mode: it must die out in the transient periods
_FRICTION, _EPSILON, _HARDENING = 0.1, 2e-3, 2e7  # N, m/s, N/m³


def gvt_structure():
    """Mass, damping and stiffness matrices of the test structure and its joint terms.

    Returns
    -------
    M, C, K : ndarray, shape (12, 12)
        Free-free chain on two suspension springs; 1.5 % modal damping (10 % for the
        suspension mode, which the transient periods must let die out).
    terms : tuple of Term
        The joint: ``tanh((v7-v8)/ε)`` and ``(x7-x8)**3`` between DOFs 7 and 8.
    coefficients : ndarray, shape (2,)
        Friction force [N] and hardening stiffness [N/m³].
    """
    n = len(_MASSES)
    K = np.zeros((n, n))
    for i, k in enumerate(_SPRINGS):
        K[i : i + 2, i : i + 2] += k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    K[0, 0] += _SUSPENSION
    K[-1, -1] += _SUSPENSION
    M = np.diag(_MASSES)
    C = modal_damping(M, K, [_SUSPENSION_DAMPING] + [_DAMPING] * (n - 1))
    j, k = GVT_JOINT
    terms = (Term(f"tanh((v{j}-v{k})/{_EPSILON:g})", (j, k)), Term(f"(x{j}-x{k})**3", (j, k)))
    return M, C, K, terms, np.array([_FRICTION, _HARDENING])


@dataclass(frozen=True, eq=False)
class GVTRecord:
    """One realisation at one level: force and accelerometer signals, whole periods.

    Attributes
    ----------
    level : float
        Force rms [N].
    realisation : int
    fs : float
        Sampling frequency [Hz].
    period : int
        Samples per period.
    force : ndarray, shape (n_samples, 1)
        Shaker force [N] at DOF ``GVT_SHAKER``.
    acceleration : ndarray, shape (n_samples, 3)
        Noisy accelerations [m/s²] at ``GVT_SENSORS``.
    displacement, velocity : ndarray, shape (n_samples, 3)
        The exact (noise-free) motion at the sensors, for checks.
    lines : ndarray of int
        Excited DFT lines of one period.
    """

    level: float
    realisation: int
    fs: float
    period: int
    force: np.ndarray
    acceleration: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    lines: np.ndarray


def gvt_records(
    levels=(0.1, 1.0, 8.0),
    n_realisations: int = 2,
    *,
    n_periods: int = 4,
    transient: int = 2,
    period: int = 2048,
    fs: float = 64.0,
    noise: float = 1.5,
    seed: int = 0,
) -> list[GVTRecord]:
    """Simulate the ground vibration test at each level and realisation (steady state only).

    Parameters
    ----------
    levels : sequence of float
        Force rms of each amplitude level [N].
    n_realisations : int
        Realisations per level (new phases, the same random-odd lines).
    n_periods : int
        Periods kept per realisation.
    transient : int
        Leading periods simulated and dropped (the suspension mode decays as e^{-0.31 t}, the
        1.95 Hz mode as e^{-0.18 t}).
    period : int
        Samples per period.
    fs : float
        Sampling frequency [Hz] (the highest mode is at 16.3 Hz).
    noise : float
        Accelerometer noise [% of each channel's std].
    seed : int
        Root seed (lines, phases, noise).

    Returns
    -------
    list of GVTRecord
        Level-major, then realisation.
    """
    if not levels or any(not (np.isfinite(a) and a > 0) for a in levels):
        raise InputDataError(f"levels must be positive force rms values [N], got {levels!r}")
    M, C, K, terms, coefs = gvt_structure()
    rng = np.random.default_rng(seed)
    lines = multisine_lines(period, fs, GVT_BAND_HZ, "random-odd", rng)
    out: list[GVTRecord] = []
    sensors = np.array(GVT_SENSORS) - 1
    for level in levels:
        forces = [multisine(period, fs, GVT_BAND_HZ, level, rng, n_periods=n_periods + transient, lines=lines)
                  for _ in range(n_realisations)]
        response = simulate_response(M, C, K, [GVT_SHAKER], np.stack([f.fine for f in forces]),
                                     fs * forces[0].oversample, forces[0].oversample, terms, coefs)
        keep = slice(transient * period, (transient + n_periods) * period)
        for r in range(n_realisations):
            acc = response.acceleration[r, keep][:, sensors]
            out.append(GVTRecord(
                level=float(level), realisation=r, fs=float(fs), period=int(period),
                force=response.force[r, keep], acceleration=add_output_noise(acc, noise, rng),
                displacement=response.displacement[r, keep][:, sensors],
                velocity=response.velocity[r, keep][:, sensors], lines=lines,
            ))
    return out
