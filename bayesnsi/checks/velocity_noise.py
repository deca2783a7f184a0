"""Velocities differentiated from noisy displacements: when velocity terms read mostly noise.

Without measured velocities every term of a velocity (``sign(v)``, ``v|v|``, ``v³``) reads the
finite-difference derivative of the measured displacement, whose noise is the displacement's
noise times the stencil's norm times the sampling rate (0.95 fs for the default fourth-order
stencil). A position sensor whose noise is a small share of a free body's travel can still give
a velocity that is mostly noise: on a free-free two-mass rig sampled at 500 Hz (travel std
0.084 m), 2 % position noise gave the derived velocity a noise of 0.80 m/s against the
velocity's own std of 0.13 m/s (0.98 of the derived velocity's std) and ``select`` ranked
Coulomb friction at the wrong mass first (P = 0.99, AR(1)); with 0.1 mm (0.12 %, ratio 0.34) a
negative v|v| replaced the true sign(v2); with 0.01 mm (0.036) and 1 µm (0.004) the true model
won. On the reference cases at 2 % noise (velocities derived instead of measured) the ratio is
0.08-0.14. :func:`velocity_noise_findings` says so, per velocity a candidate reads, when the
ratio reaches :data:`VELOCITY_NOISE_LIMIT`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..findings import Finding
from ..noise import white_noise_std
from ..signals import Signals, differentiate

__all__ = ["VELOCITY_NOISE_LIMIT", "velocity_noise_findings"]

VELOCITY_NOISE_LIMIT = 0.3
"""Noise std of a derived velocity over its std from which the selection warns."""


def _stencil_norm(method: str) -> float:
    """``‖stencil‖`` of :func:`bayesnsi.signals.differentiate` at unit sampling rate (white-noise gain)."""
    impulse = np.zeros((41, 1))
    impulse[20] = 1.0
    return float(np.linalg.norm(differentiate(impulse, 1.0, method)[8:-8]))


def velocity_noise_findings(signals: Signals, candidates: Sequence, velocity_method: str = "fourth") -> list[Finding]:
    """Findings for the derived velocities the candidates read that are mostly noise.

    Parameters
    ----------
    signals : Signals
        Estimation data; with measured velocities nothing is derived and the list is empty.
    candidates : sequence of CandidateModel
        Their terms name the velocities that are read.
    velocity_method : str
        The finite-difference stencil (``[nsi] velocity_method``).

    Returns
    -------
    list of Finding
        Kind ``"data.velocity_noise"``, one per DOF (subject ``v<k>``) whose derived velocity's noise std is at least
        :data:`VELOCITY_NOISE_LIMIT` times the derived velocity's std.
    """
    if signals.velocity is not None:
        return []
    read = sorted({d for c in candidates for t in c.terms for d in t.expr.velocity_dofs})
    read = [d for d in read if d in signals.output_dofs]
    if not read:
        return []
    x = np.asarray(signals.displacement, dtype=float)
    x_noise = white_noise_std(x)
    noise = x_noise * signals.fs * _stencil_norm(velocity_method)
    spread = differentiate(x, signals.fs, velocity_method).std(axis=0)
    out = []
    for dof in read:
        i = list(signals.output_dofs).index(dof)
        ratio = float(noise[i] / spread[i]) if spread[i] > 0 else np.inf
        if ratio < VELOCITY_NOISE_LIMIT:
            continue
        terms = sorted({t.expr.text for c in candidates for t in c.terms if dof in t.expr.velocity_dofs})
        message = (
            f"the velocity v{dof} is differentiated from the displacement x{dof}, whose noise "
            f"({x_noise[i]:.3g}, high-order differences) gives it a noise of {noise[i]:.3g} "
            f"= {ratio:.2f} of its std at {signals.fs:g} Hz: the terms of v{dof} ({', '.join(terms)}) read a "
            "noisy velocity (errors in variables: friction is attenuated and another term can take its "
            "place, whatever the probabilities say); measure the velocity ([data] velocities), use a "
            "position sensor with less noise, or decimate (the derived velocity's noise grows with the "
            "sampling rate)"
        )
        values = {"displacement_noise": float(x_noise[i]), "velocity_noise": float(noise[i]), "ratio": ratio,
                  "limit": VELOCITY_NOISE_LIMIT, "fs": float(signals.fs)}
        out.append(Finding("data.velocity_noise", message, f"v{dof}", "warning", values))
    return out
