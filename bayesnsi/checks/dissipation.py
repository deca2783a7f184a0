"""Negative dissipation: a friction or damping term whose identified coefficient feeds energy in.

A pure velocity term that is odd in the velocity and dissipative in shape (``n(v)·v >= 0`` with v
the velocity at its location, relative for an element: ``v|v|``, ``v^3``, ``sign(v)``,
``tanh(v/eps)``) adds the force ``-λ l n`` to the equation of motion
``M ẅ + C ẇ + K w + λ l n = F f`` (extended input ``[f; -n]``), whose power ``-λ n(v)·v`` is
positive for every motion when ``λ < 0``. That is physics, not a tolerance: a negative quadratic
damping fitted to a Coulomb joint on one level diverges on a stronger one. The loop refuses such an
effect (:mod:`bayesnsi.loop.guards`) and the selection's checks report such a model
(:mod:`bayesnsi.checks.adequacy`).
"""

from __future__ import annotations

import numpy as np

from ..models import Term

__all__ = ["dissipative_shape", "injects_energy"]

_PROBE = np.random.default_rng(20_261_126).choice([-1.0, 1.0], (4, 64)) * 10.0 ** np.random.default_rng(
    20_261_127).uniform(-6.0, 3.0, (4, 64))


def dissipative_shape(term: Term) -> bool:
    """True for a pure velocity term, odd in the velocity, with ``n(v)·v >= 0`` at its location.

    Checked on a fixed probe of velocities of both signs spanning 1e-6 to 1e3 (v the DOF's
    velocity for a grounded term, ``v_j - v_k`` for an element between j and k).

    Parameters
    ----------
    term : Term

    Returns
    -------
    bool
        True for ``v|v|``, ``v^3``, ``sign(v)``, ``tanh(v/eps)`` (and their element forms); False
        for any term that reads a displacement, reads velocities off its location, or is not odd
        (``sign(v)+``, ``v+``).
    """
    expr = term.expr
    if expr.displacement_dofs or not expr.velocity_dofs or not set(expr.velocity_dofs) <= set(term.at):
        return False
    dofs = sorted(set(term.at))
    if len(dofs) > _PROBE.shape[0]:
        return False
    v = {d - 1: _PROBE[i] for i, d in enumerate(dofs)}
    n = expr.evaluate({}, v)
    n_minus = expr.evaluate({}, {k: -a for k, a in v.items()})
    relative = v[term.at[0] - 1] - (v[term.at[1] - 1] if len(term.at) == 2 else 0.0)
    power = n * relative
    scale = np.abs(n) * np.abs(relative)
    odd = np.allclose(n_minus, -n, rtol=1e-9, atol=0.0)
    return bool(odd and np.all(np.isfinite(power)) and np.all(power >= -1e-12 * scale) and np.any(power > 0))


def injects_energy(term: Term, coefficient: float) -> bool:
    """True when ``term`` with ``coefficient`` λ does positive work on every motion (module notes).

    Parameters
    ----------
    term : Term
    coefficient : float
        Its identified coefficient λ (real part).

    Returns
    -------
    bool
        ``λ < 0`` for a term of :func:`dissipative_shape`; False otherwise.
    """
    return bool(np.isfinite(coefficient) and coefficient < 0 and dissipative_shape(term))
