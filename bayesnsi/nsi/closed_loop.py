"""Closed-loop simulation of an identified candidate: the nonlinear inputs fed back from its own response.

Used by the closed-loop reconstruction (:func:`bayesnsi.nsi.reconstruct.reconstruct`, docs/method.md §5)
and by the model replicates of :mod:`bayesnsi.uncertainty.surrogate` (docs/method.md §11), which drive
many records at once and with the interval-mean inputs the identification assumed.
"""

from __future__ import annotations

import numpy as np

from ..exceptions import UnstableModelError
from ..models.hysteresis import boucwen_step

__all__ = ["closed_loop_response", "divergence_bound"]

_FIXED_POINT_ITERATIONS = 4


def closed_loop_response(
    result, force, x0, bound: float, n_dofs: int = 0, fs: float = 1.0, interval_mean: bool = False,
    subsamples: int = 4, stride: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """The identified model's free response in closed loop: its displacements and velocities (docs/method.md §5).

    The nonlinear inputs ``n_i`` are evaluated on the model's own output displacements and
    velocities (velocity output ``C A_c x``) at each sample, on the model's grid. A term with
    memory (``boucwen``, docs/method.md §12) is an internal state of the model: z = 0 at the first
    sample, advanced from sample to sample along the model's output displacement by the rule of
    its identification (:func:`bayesnsi.models.hysteresis.boucwen_step`). A third axis of
    ``force`` simulates that many records at once (one pass over the samples).

    Parameters
    ----------
    result : NSIResult
    force : array_like, shape (n_samples, m) or (n_samples, m, r)
        The forces on the model's grid (``fs · upsample``); with a third axis, ``r`` records.
    x0 : array_like, shape (n,) or (n, r)
        Initial state(s).
    bound : float
        A state beyond this magnitude counts as divergence.
    n_dofs : int
        Number of DOFs of the record (at least the terms' and outputs' highest DOF is used).
    fs : float
        The grid's sampling rate [Hz].
    interval_mean : bool
        Drive the model with the inputs its ``input_hold = "average"`` identification assumed
        (:func:`bayesnsi.nsi.feedback.extended_input`): the forces' band-limited interval means,
        and the nonlinear inputs' means over each interval by the midpoint rule on ``subsamples``
        points, the displacement interpolated by cubic Hermite polynomials and the velocity
        linearly towards the end of the interval predicted with the previous interval's inputs
        (not with a feedthrough of the nonlinear inputs, ``D`` ≠ 0: point values then).
        Default: point values (``input_hold = "sample"``).
    subsamples : int
        Quadrature points per interval with ``interval_mean``.
    stride : int
        Keep every ``stride``-th sample of the response (e.g. the upsampling factor: the data's
        samples), so that long records of many replicates fit in memory.

    Returns
    -------
    displacement, velocity : ndarray, shape (ceil(n_samples / stride), l), or with ``r`` last
        At the output DOFs.

    Raises
    ------
    UnstableModelError
        When the simulation of any record diverges.
    """
    model = result.free_model
    terms = result.terms
    m = len(result.input_dofs)
    A, B, C, D = model.A, model.B, model.C, model.D
    c_vel = C @ model.continuous_state_matrix()
    force = np.asarray(force, dtype=float)
    batch = force.ndim == 3
    force = force.reshape(len(force), m, force.shape[2] if batch else 1)
    n_samples, n_out, n_rec = len(force), C.shape[0], force.shape[2]
    rows = np.array(result.output_dofs) - 1
    n_dofs = max([int(n_dofs), int(rows.max(initial=-1)) + 1] + [max(t.dofs) for t in terms])
    b_nl, d_nl = B[:, m:], D[:, m:]
    implicit = bool(np.any(d_nl != 0))  # y_k depends on n(y_k): solve by fixed-point iteration
    averaged = interval_mean and not implicit
    if averaged:
        from .feedback import _band_limited_interval_mean

        force = _band_limited_interval_mean(force.reshape(n_samples, -1)).reshape(force.shape)
    b_force, d_force = B[:, :m], D[:, :m]
    outputs = np.vstack([C, c_vel])  # displacement and velocity outputs in one product
    x = np.array(np.broadcast_to(np.asarray(x0, dtype=float).reshape(A.shape[0], -1), (A.shape[0], n_rec)))
    functions = [_Memory(term.expr, n_rec) if term.expr.memory is not None else term.expr.function for term in terms]
    if averaged:
        out, vel = _interval_mean_loop(A, (b_force, b_nl, d_force), outputs, force, functions, x, rows, n_dofs,
                                       (bound, 1.0 / fs, int(subsamples), result.candidate.name, int(stride)))
        return (out, vel) if batch else (out[:, :, 0], vel[:, :, 0])
    out, vel = _kept_arrays(n_samples, int(stride), n_out, n_rec)
    xs = np.full((n_dofs, n_rec), np.nan)
    vs = np.full((n_dofs, n_rec), np.nan)
    nl = np.zeros((len(terms), n_rec))
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging state is caught every 64 samples
        for k in range(n_samples):
            both = outputs @ x
            linear_part = both[:n_out] + d_force @ force[k]
            vs[rows] = both[n_out:]
            for _ in range(_FIXED_POINT_ITERATIONS if implicit else 1):
                yk = linear_part - d_nl @ nl if implicit else linear_part
                xs[rows] = yk
                for idx, function in enumerate(functions):
                    nl[idx] = function(xs, vs)
            for function in functions:
                if isinstance(function, _Memory):
                    function.commit()
            if k % stride == 0:
                out[k // stride], vel[k // stride] = yk, vs[rows]
            x = A @ x + b_force @ force[k] - b_nl @ nl
            _check_bounded(x, k, n_samples, bound, result.candidate.name, k / fs)
    return (out, vel) if batch else (out[:, :, 0], vel[:, :, 0])


def divergence_bound(displacement) -> float:
    """The state magnitude past which a closed-loop simulation of a record counts as diverged.

    Parameters
    ----------
    displacement : array_like
        The measured displacements of the record.

    Returns
    -------
    float
        ``1e6 · max(1, max |displacement|)``.
    """
    return 1e6 * max(1.0, float(np.max(np.abs(displacement))))


def _kept_arrays(n_samples: int, stride: int, n_out: int, n_rec: int) -> tuple[np.ndarray, np.ndarray]:
    """Empty displacement and velocity arrays for every ``stride``-th of ``n_samples`` samples."""
    kept = -(-n_samples // stride)
    return np.empty((kept, n_out, n_rec)), np.empty((kept, n_out, n_rec))


def _check_bounded(x: np.ndarray, k: int, n_samples: int, bound: float, name: str, time: float) -> None:
    """Raise UnstableModelError when the state has left ``bound`` (checked every 64 samples and at the end)."""
    if (k % 64 == 63 or k == n_samples - 1) and not np.abs(x).max() < bound:
        raise UnstableModelError(
            f"closed-loop simulation of {name!r} diverged by sample {k} (t = {time:.3g} s): the model is unstable "
            "in feedback"
        )


class _Memory:
    """A ``boucwen`` term's state in a closed-loop simulation: z and the displacement it last followed."""

    def __init__(self, expr, n_rec: int) -> None:
        self.shape, self.argument = expr.memory, expr.memory_argument
        self.z = np.zeros(n_rec)
        self.at: np.ndarray | None = None
        self.pending: tuple[np.ndarray, np.ndarray] | None = None

    def advanced(self, xs, vs) -> tuple[np.ndarray, np.ndarray]:
        """z at the displacement of ``xs`` (not kept) and that displacement."""
        at = np.array(self.argument(xs, vs), dtype=float)  # a copy: the argument may be a view of ``xs``
        return (self.z.copy() if self.at is None else boucwen_step(self.shape, self.z, at - self.at)), at

    def __call__(self, xs, vs) -> np.ndarray:
        """z at the current sample, kept by :meth:`commit` (the last call of a fixed-point iteration wins)."""
        self.pending = self.advanced(xs, vs)
        return self.pending[0]

    def commit(self) -> None:
        if self.pending is not None:
            self.z, self.at = self.pending
            self.pending = None

    def interval(self, start, end, vs) -> np.ndarray:
        """The trapezoid mean of z over an interval from the displacement ``start`` to ``end``; keeps z at its start."""
        self(start, vs)
        self.commit()
        z_end = boucwen_step(self.shape, self.z, np.array(self.argument(end, vs), dtype=float) - self.at)
        return 0.5 * (self.z + z_end)


def _interval_mean_loop(A, gains, outputs, force, functions, x, rows, n_dofs, settings):
    """:func:`closed_loop_response` with interval-mean nonlinear inputs (predictor-corrector per sample)."""
    (b_force, b_nl, d_force), (bound, dt, subsamples, name, stride) = gains, settings
    n_samples, n_rec, n_out = len(force), x.shape[1], len(rows)
    s = ((np.arange(subsamples) + 0.5) / subsamples)[:, None]  # quadrature points, shape (S, 1)
    add, weight = np.add.reduce, 1.0 / subsamples
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, dt * (s**3 - 2 * s**2 + s), -2 * s**3 + 3 * s**2, dt * (s**3 - s**2)
    out, vel = _kept_arrays(n_samples, stride, n_out, n_rec)
    xs = np.full((n_dofs, subsamples, n_rec), np.nan)
    vs = np.full((n_dofs, subsamples, n_rec), np.nan)
    ends = np.full((2, n_dofs, n_rec), np.nan)  # the interval's start and end, for a term with memory
    nl = np.zeros((len(functions), n_rec))
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging state is caught every 64 samples
        for k in range(n_samples):
            now = outputs @ x
            y_now, v_now = now[:n_out] + d_force @ force[k], now[n_out:]
            if k % stride == 0:
                out[k // stride], vel[k // stride] = y_now, v_now
            free = A @ x + b_force @ force[k]
            ahead = outputs @ (free - b_nl @ nl)  # the interval's end, predicted with the previous inputs
            y0, v0, y1, v1 = y_now[:, None], v_now[:, None], ahead[:n_out, None], ahead[n_out:, None]
            xs[rows] = h00 * y0 + h10 * v0 + h01 * y1 + h11 * v1
            vs[rows] = v0 + s * (v1 - v0)
            ends[0][rows], ends[1][rows] = y_now, ahead[:n_out]
            for idx, function in enumerate(functions):
                if isinstance(function, _Memory):
                    nl[idx] = function.interval(ends[0], ends[1], None)
                    continue
                value = function(xs, vs)
                nl[idx] = add(value, axis=0) * weight if np.ndim(value) == 2 else value  # a constant: itself
            x = free - b_nl @ nl
            _check_bounded(x, k, n_samples, bound, name, k * dt)
    return out, vel
