"""Curves that figures draw, computed by the library (the plots compute nothing).

:func:`effect_curve` evaluates the force λ·n(x, v) of one identified nonlinear term on the
measured signals, against the displacement and velocity at its location (relative ones for a
term acting between two DOFs), thinned to a number of points a scatter plot can show.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .exceptions import InputDataError

__all__ = ["EffectCurve", "effect_curve"]


@dataclass(frozen=True, eq=False)
class EffectCurve:
    """The force of one term against the state at its location.

    Attributes
    ----------
    displacement, velocity : ndarray, shape (n_points,)
        Displacement [m] and velocity [m/s] at the term's DOF, or DOF j minus DOF k for a term
        at the pair (j, k).
    force : ndarray, shape (n_points,)
        λ·n(x, v) [N] at the same instants.
    displacement_label, velocity_label : str
        Axis labels (``"x3"``, ``"v3"`` or ``"relative displacement"``, ...).
    title : str
        Term and coefficient, e.g. ``"sign(v2) @2: λ = 1.02"``.
    """

    displacement: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    displacement_label: str
    velocity_label: str
    title: str


def effect_curve(step, signals, max_points: int = 4000) -> EffectCurve:
    """Force λ·n(x, v) of a term on measured signals, against x and v at its location.

    Parameters
    ----------
    step : object with ``term`` (:class:`~bayesnsi.models.Term`) and ``coefficient`` (float)
        E.g. an accepted step of :func:`bayesnsi.diagnose.close_the_loop`.
    signals : Signals
        Measured signals; the term's location DOFs must be measured outputs.
    max_points : int
        At most this many instants, evenly spread over the record.

    Returns
    -------
    EffectCurve

    Raises
    ------
    InputDataError
        If ``max_points`` is below 1 or a DOF the term acts at or reads is not a measured output.
    """
    if int(max_points) != max_points or max_points < 1:
        raise InputDataError(f"max_points must be a positive integer, got {max_points!r}")
    term = step.term
    outputs = list(signals.output_dofs)
    read = (*term.at, *term.expr.displacement_dofs, *term.expr.velocity_dofs)
    missing = [d for d in read if d not in outputs]
    if missing:
        raise InputDataError(f"term {term.name} needs DOF {missing[0]}, which is not a measured output {outputs}")
    x, v = signals.state_rows(term.expr.displacement_dofs, term.expr.velocity_dofs)
    force = step.coefficient * term.evaluate(x, v)
    velocities = signals.velocities()
    j = outputs.index(term.at[0])
    xs, vs = signals.displacement[:, j], velocities[:, j]
    if len(term.at) == 2:
        k = outputs.index(term.at[1])
        xs, vs = xs - signals.displacement[:, k], vs - velocities[:, k]
        labels = ("relative displacement", "relative velocity")
    else:
        labels = (f"x{term.at[0]}", f"v{term.at[0]}")
    pick = np.linspace(0, len(force) - 1, min(int(max_points), len(force))).astype(int)
    return EffectCurve(
        displacement=xs[pick],
        velocity=vs[pick],
        force=np.asarray(force)[pick],
        displacement_label=labels[0],
        velocity_label=labels[1],
        title=f"{term.name}: λ = {step.coefficient:.4g}",
    )
