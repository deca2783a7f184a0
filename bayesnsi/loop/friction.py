"""The physical reading of a one-DOF friction model: viscous forwards and backwards, Coulomb level, offset.

docs/method.md §11. A model of a positioning axis (or any one-DOF structure forced where it is
measured) ``M a + C v + K x + Σ λ_i n_i(x, v) = f`` holds a friction law in its velocity terms.
Wherever that law is piecewise linear in the velocity (``v``, ``sign(v)``, ``|v|``, ``v+``,
``sign(v)+``, a constant), it reads, moving forwards (v > 0) and backwards (v < 0),

    F(v) = A₊ + B₊ v   (v > 0),        F(v) = A₋ + B₋ v   (v < 0),

with the forward and backward viscous coefficients ``B₊``, ``B₋``, the Coulomb level
``(A₊ - A₋)/2`` and the offset ``(A₊ + A₋)/2`` (the constant force, which makes the Coulomb
friction asymmetric: ``A₊`` forwards, ``-A₋`` backwards). With ``C v + λ_s sign(v) + λ_d |v| + c``:
``B₊ = C + λ_d``, ``B₋ = C - λ_d``, Coulomb ``λ_s``, offset ``c``.

The coefficients are read where a one-DOF model's evidence scores them, the force it predicts from
the measured motion (:func:`bayesnsi.nsi.force_affine`, IDIM view; the published EMPS parameters are
least squares in that view): least squares of the filtered force on ``[a, v, x, 1, n_i]``, one sample
per correlation time of the filter, with the Gaussian covariance of the estimate for the 95 %
intervals. Terms that are not piecewise linear in the velocity (``v|v|``, ``tanh``, displacement
terms) take part in the fit and are listed in ``other``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import NotIdentifiableError
from ..nsi.inverse import edge_samples, filtered_kinematics, inverse_force, parallel_filter

__all__ = ["FrictionReading", "friction_reading", "holds_friction"]

_Z95 = 1.959963984540054  # two-sided 95 % quantile of the normal distribution
_PROBE = np.array([-2.0, -1.0, 1.0, 2.0])  # velocities at which a term's piecewise-linear form is read


@dataclass(frozen=True)
class FrictionReading:
    """Friction parameters of a one-DOF model with their 95 % intervals (module notes).

    Attributes
    ----------
    dof : int
    mass : float
        M [kg].
    viscous_forward, viscous_backward : float
        ``B₊``, ``B₋`` [N s/m]: the slope of the friction law moving forwards and backwards.
    coulomb : float
        The Coulomb level ``(A₊ - A₋)/2`` [N].
    offset : float
        The constant force ``(A₊ + A₋)/2`` [N] (only meaningful on data whose force keeps its mean).
    intervals : dict of str to (float, float)
        95 % intervals of ``mass``, ``viscous_forward``, ``viscous_backward``, ``coulomb``, ``offset``.
    force_rmse : float
        RMS of the force residual of the fit [N] (filtered force, edges left out).
    terms : tuple of str
        The model's terms (their names).
    other : tuple of str
        Terms that are not piecewise linear in the velocity (fitted, not part of the reading).
    parameters : tuple of float
        The least-squares estimate of ``[M, C, K, c, λ_1, ..., λ_q]`` (the linear part, the constant
        force and the terms' coefficients) that :meth:`force_error` predicts with.
    model_terms : tuple of Term
        The terms, for :meth:`force_error`.
    """

    dof: int
    mass: float
    viscous_forward: float
    viscous_backward: float
    coulomb: float
    offset: float
    intervals: dict
    force_rmse: float
    terms: tuple[str, ...]
    other: tuple[str, ...] = ()
    parameters: tuple[float, ...] = ()
    model_terms: tuple = ()

    def force_error(self, signals, cutoff_hz: float | None = None) -> float:
        """RMS error [N] of the force this reading predicts from the measured motion of other data (held out).

        Parameters
        ----------
        signals : Signals
            One force and one displacement at the reading's DOF (keep the force's mean).
        cutoff_hz : float, optional
            As in :func:`friction_reading`.

        Returns
        -------
        float
        """
        x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
        mass, damping, stiffness, offset, *coefficients = self.parameters
        predicted = inverse_force(mass, damping, stiffness, self.model_terms, coefficients, x, v, a, offset,
                                  fs=signals.fs, cutoff_hz=cutoff)
        trim = edge_samples(signals.fs, cutoff)
        return float(np.sqrt(np.mean((f - predicted)[trim:len(f) - trim] ** 2)))

    def as_dict(self) -> dict:
        """The reading as a plain dict (results.json): values and ``[low, high]`` intervals."""
        names = ("mass", "viscous_forward", "viscous_backward", "coulomb", "offset")
        return {
            "dof": self.dof,
            **{n: getattr(self, n) for n in names},
            "intervals": {n: list(self.intervals[n]) for n in names},
            "force_rmse": self.force_rmse,
            "terms": list(self.terms),
            "other": list(self.other),
        }


def _piecewise_linear(term, dof: int):
    """``(A₊, B₊, A₋, B₋)`` of a pure velocity term at ``dof`` that is linear on each side of v = 0, else None."""
    expr = term.expr
    if expr.displacement_dofs or set(expr.velocity_dofs) - {dof}:
        return None
    rows = np.zeros((dof, _PROBE.size))
    rows[dof - 1] = _PROBE
    with np.errstate(all="ignore"):
        n = np.broadcast_to(np.asarray(term.evaluate(np.zeros_like(rows), rows), dtype=float), _PROBE.shape)
    if not np.all(np.isfinite(n)):
        return None
    slope_minus, slope_plus = n[1] - n[0], n[3] - n[2]
    intercept_minus, intercept_plus = n[1] + slope_minus, n[2] - slope_plus
    # linear on each side: check at a third velocity per side
    check = np.array([-3.0, 3.0])
    rows3 = np.zeros((dof, 2))
    rows3[dof - 1] = check
    with np.errstate(all="ignore"):
        n3 = np.broadcast_to(np.asarray(term.evaluate(np.zeros_like(rows3), rows3), dtype=float), (2,))
    expected = np.array([intercept_minus - 3.0 * slope_minus, intercept_plus + 3.0 * slope_plus])
    if not np.allclose(n3, expected, rtol=1e-9, atol=1e-12):
        return None
    return intercept_plus, slope_plus, intercept_minus, slope_minus


def holds_friction(result) -> bool:
    """True for a one-DOF model with a velocity term that is piecewise linear and not linear (a friction law).

    Parameters
    ----------
    result : NSIResult

    Returns
    -------
    bool
        ``sign(v)``, ``|v|``, ``v·[v > 0]``, ``sign(v)+`` (not ``v|v|``, ``tanh``, displacement terms).
    """
    if not result.physical_parameters:
        return False
    dof = max((d for t in result.terms for d in t.expr.velocity_dofs), default=1)
    for term in result.terms:
        if not term.expr.velocity_dofs:
            continue
        form = _piecewise_linear(term, dof)
        if form is not None and not (form[0] == form[2] == 0.0 and form[1] == form[3]):
            return True
    return False


def friction_reading(result, signals, cutoff_hz: float | None = None) -> FrictionReading:
    """Forward and backward viscous coefficients, Coulomb level and offset of a one-DOF model (module notes).

    Parameters
    ----------
    result : NSIResult
        A one-DOF model (one force and one displacement at the same DOF), e.g. a loop's final model.
    signals : Signals
        The data to read it on; keep the force's mean (``[data] remove_mean = false``) for the offset.
    cutoff_hz : float, optional
        Cutoff of the force view's low-pass filter (default fs/20, :func:`bayesnsi.nsi.force_affine`).

    Returns
    -------
    FrictionReading

    Raises
    ------
    NotIdentifiableError
        When the model is not a one-DOF model.
    """
    if not result.physical_parameters or len(signals.output_dofs) != 1:
        raise NotIdentifiableError(
            f"candidate {result.candidate.name!r}: a friction reading needs a one-DOF model (one force and one "
            "displacement at the same DOF)"
        )
    dof = int(signals.output_dofs[0])
    x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
    step = max(1, int(signals.fs / cutoff))
    trim = edge_samples(signals.fs, cutoff)
    keep = slice(trim, len(f) - trim, step)
    rows_x, rows_v = np.zeros((dof, len(x))), np.zeros((dof, len(x)))
    rows_x[dof - 1], rows_v[dof - 1] = x, v
    columns = [a, v, x, np.ones_like(x)]
    for term in result.terms:
        with np.errstate(all="ignore"):
            column = np.broadcast_to(np.asarray(term.evaluate(rows_x, rows_v), dtype=float), x.shape)
        columns.append(parallel_filter(column, signals.fs, cutoff) if np.ptp(column) > 0 else column)
    design = np.column_stack(columns)[keep]
    force = f[keep]
    theta, *_ = np.linalg.lstsq(design, force, rcond=None)
    residual = force - design @ theta
    dof_fit = max(len(force) - design.shape[1], 1)
    covariance = float(residual @ residual) / dof_fit * np.linalg.pinv(design.T @ design)
    # each parameter as a linear functional of theta: [mass, B+, B-, coulomb, offset]
    weights = np.zeros((5, design.shape[1]))
    weights[0, 0] = 1.0
    weights[1, 1] = weights[2, 1] = 1.0  # the linear damping C v
    weights[4, 3] = 1.0  # the constant column
    other = []
    for k, term in enumerate(result.terms, start=4):
        form = _piecewise_linear(term, dof)
        if form is None:
            other.append(term.name)
            continue
        a_plus, b_plus, a_minus, b_minus = form
        weights[1, k], weights[2, k] = b_plus, b_minus
        weights[3, k] = (a_plus - a_minus) / 2.0
        weights[4, k] += (a_plus + a_minus) / 2.0
    values = weights @ theta
    sd = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", weights, covariance, weights), 0.0))
    names = ("mass", "viscous_forward", "viscous_backward", "coulomb", "offset")
    intervals = {n: (float(m - _Z95 * s), float(m + _Z95 * s)) for n, m, s in zip(names, values, sd)}
    return FrictionReading(
        dof=dof,
        mass=float(values[0]),
        viscous_forward=float(values[1]),
        viscous_backward=float(values[2]),
        coulomb=float(values[3]),
        offset=float(values[4]),
        intervals=intervals,
        force_rmse=float(np.sqrt(np.mean(residual**2))),
        terms=tuple(t.name for t in result.terms),
        other=tuple(other),
        parameters=tuple(float(t) for t in theta),
        model_terms=tuple(result.terms),
    )
