"""The one data container: measured forces and responses with their DOF maps.

Array convention (used throughout bayesnsi): time signals are ``(n_samples, n_channels)``;
DOFs are numbered from 1 as in the paper; frequencies in Hz are named ``*_hz`` and angular
frequencies ``omega`` [rad/s].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .exceptions import InputDataError, ShapeError

__all__ = ["Signals", "differentiate", "MIN_FS", "MAX_FS", "MEASURED_QUANTITIES"]

MIN_FS = 1e-6
"""Lowest accepted sampling frequency [Hz] (one sample every 11.6 days)."""
MAX_FS = 1e9
"""Highest accepted sampling frequency [Hz] (1 GHz, far above any structural measurement)."""
MEASURED_QUANTITIES = ("displacement", "velocity", "acceleration")
"""What the response sensors can measure (``Signals.measured``; errors are reported in it)."""

_DIFFERENTIATORS = {
    # central-difference stencils (coefficients for offsets -k..k, divided by dt)
    "central": np.array([-0.5, 0.0, 0.5]),
    "fourth": np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0,
    "sixth": np.array([-1.0, 9.0, -45.0, 0.0, 45.0, -9.0, 1.0]) / 60.0,
}


def differentiate(signal, fs: float, method: str = "fourth") -> np.ndarray:
    """Velocity from displacement by a central finite-difference stencil.

    Parameters
    ----------
    signal : array_like, shape (n_samples, n_channels)
        Displacements [m].
    fs : float
        Sampling frequency [Hz].
    method : {"central", "fourth", "sixth"}
        Stencil order 2, 4 or 6. The gain at ω is sin-series exact to that order: with
        x = ωΔt the relative gain error is about -x²/6 (central), -x⁴/30 (fourth),
        -x⁶/140 (sixth). Higher orders amplify noise near Nyquist a little more.
        The ends use one-sided differences of second order.

    Returns
    -------
    ndarray, shape (n_samples, n_channels)
        Velocities [m/s]; the input is not modified.
    """
    if method not in _DIFFERENTIATORS:
        raise InputDataError(f"unknown differentiator {method!r}; use one of {sorted(_DIFFERENTIATORS)}")
    y = np.asarray(signal, dtype=float)
    squeeze = y.ndim == 1
    y = y.reshape(len(y), -1)
    stencil = _DIFFERENTIATORS[method]
    half = len(stencil) // 2
    if len(y) < len(stencil) + 2:
        raise InputDataError(f"need at least {len(stencil) + 2} samples to differentiate, got {len(y)}")
    out = np.empty_like(y)
    n = len(y)
    acc = np.zeros((n - 2 * half, y.shape[1]))
    for offset, c in zip(range(-half, half + 1), stencil):
        if c:
            acc += c * y[half + offset : n - half + offset]
    out[half : n - half] = acc * fs
    grad = np.gradient(y, 1.0 / fs, axis=0, edge_order=2)
    out[:half] = grad[:half]
    out[n - half :] = grad[n - half :]
    return out[:, 0] if squeeze else out


def _as_matrix(name: str, values, n_samples: int | None) -> np.ndarray:
    arr = np.array(values, dtype=float, copy=True)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ShapeError(f"{name} must have shape (n_samples, n_channels), got shape {arr.shape}")
    if n_samples is not None and arr.shape[0] != n_samples:
        raise ShapeError(
            f"{name} has {arr.shape[0]} samples but the forces have {n_samples}; "
            "all channels must be sampled together - trim them to the same length"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise InputDataError(
            f"{name} holds {int(bad.sum())} NaN/Inf values (first at sample {row}, channel {col}); "
            "remove or interpolate them, or select a clean segment"
        )
    std = arr.std(axis=0)
    if arr.shape[0] > 1 and np.any(std == 0):
        raise InputDataError(
            f"{name} channel {int(np.argmax(std == 0))} is constant; a constant channel carries no "
            "dynamic information - remove it from the config"
        )
    arr.setflags(write=False)
    return arr


def _as_dofs(name: str, dofs, n_channels: int) -> tuple[int, ...]:
    dofs = tuple(int(d) for d in np.atleast_1d(dofs))
    if len(dofs) != n_channels:
        raise ShapeError(f"{name}: {len(dofs)} DOFs given for {n_channels} channels")
    if any(d < 1 for d in dofs):
        raise InputDataError(f"{name}: DOFs are numbered from 1, got {dofs}")
    if len(set(dofs)) != len(dofs):
        raise InputDataError(f"{name}: DOF repeated in {dofs}; map each DOF to one channel")
    return dofs


@dataclass(frozen=True)
class Signals:
    """Measured forces and responses, validated once (read-only arrays).

    Parameters
    ----------
    force : array_like, shape (n_samples, m)
        Measured forces [N] (or the input playing that role).
    displacement : array_like, shape (n_samples, l)
        Measured displacements [m] (the NSI outputs).
    fs : float
        Sampling frequency [Hz].
    input_dofs : sequence of int, length m
        DOF (1-based) at which each force acts.
    output_dofs : sequence of int, length l
        DOF of each displacement channel.
    velocity : array_like, shape (n_samples, l), optional
        Measured velocities [m/s] at ``output_dofs``; when absent they are derived with
        :func:`differentiate` where a term needs them.
    period : int, optional
        Samples per period of a periodic test (the force repeats every ``period`` samples;
        docs/method.md §11); None for a non-periodic record.
    measured : {"displacement", "velocity", "acceleration"}
        What the response sensors measured (``displacement`` holds it integrated when not a
        displacement); errors are reported in this quantity (bayesnsi._measured).
    """

    force: np.ndarray
    displacement: np.ndarray
    fs: float
    input_dofs: tuple[int, ...]
    output_dofs: tuple[int, ...]
    velocity: np.ndarray | None = None
    input_names: tuple[str, ...] = field(default=())
    output_names: tuple[str, ...] = field(default=())
    period: int | None = None
    measured: str = "displacement"

    def __post_init__(self):
        force = _as_matrix("force", self.force, None)
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("force", force)
        set_("displacement", _as_matrix("displacement", self.displacement, force.shape[0]))
        if self.velocity is not None:
            vel = _as_matrix("velocity", self.velocity, force.shape[0])
            if vel.shape[1] != self.displacement.shape[1]:
                raise ShapeError("velocity must have one column per displacement channel (same DOFs)")
            set_("velocity", vel)
        if not (isinstance(self.fs, (int, float, np.integer, np.floating)) and not isinstance(self.fs, bool)
                and MIN_FS <= self.fs <= MAX_FS):
            raise InputDataError(
                f"sampling frequency must be a number of Hz in [{MIN_FS:g}, {MAX_FS:g}], got {self.fs!r}"
            )
        set_("fs", float(self.fs))
        set_("input_dofs", _as_dofs("input_dofs", self.input_dofs, force.shape[1]))
        set_("output_dofs", _as_dofs("output_dofs", self.output_dofs, self.displacement.shape[1]))
        set_("input_names", tuple(self.input_names) or tuple(f"f{d}" for d in self.input_dofs))
        set_("output_names", tuple(self.output_names) or tuple(f"x{d}" for d in self.output_dofs))
        if self.period is not None:
            period = self.period
            if not isinstance(period, (int, np.integer)) or isinstance(period, bool) or not 2 <= period <= len(force):
                raise InputDataError(
                    f"period must be a whole number of samples in [2, {len(force)}] (the record), got {period!r}"
                )
            set_("period", int(period))
        if self.measured not in MEASURED_QUANTITIES:
            raise InputDataError(f"measured must be one of {MEASURED_QUANTITIES}, got {self.measured!r}")

    @property
    def n_samples(self) -> int:
        """Number of samples N_s."""
        return self.force.shape[0]

    @property
    def dt(self) -> float:
        """Sampling interval [s]."""
        return 1.0 / self.fs

    @property
    def n_dofs(self) -> int:
        """Largest DOF number referenced by the channels."""
        return max(self.input_dofs + self.output_dofs)

    def velocities(self, method: str = "fourth") -> np.ndarray:
        """Measured velocities, or derived from displacements by :func:`differentiate`."""
        if self.velocity is not None:
            return self.velocity
        return differentiate(self.displacement, self.fs, method)

    def segment(self, start: int, stop: int) -> Signals:
        """Samples ``start:stop`` as new Signals."""
        if not (0 <= start < stop <= self.n_samples):
            raise InputDataError(f"segment [{start}, {stop}) is outside the record of {self.n_samples} samples")
        return Signals(
            force=self.force[start:stop],
            displacement=self.displacement[start:stop],
            fs=self.fs,
            input_dofs=self.input_dofs,
            output_dofs=self.output_dofs,
            velocity=None if self.velocity is None else self.velocity[start:stop],
            input_names=self.input_names,
            output_names=self.output_names,
            period=self.period if self.period is not None and stop - start >= self.period else None,
            measured=self.measured,
        )

    def state_rows(self, displacement_dofs, velocity_dofs, velocity_method: str = "fourth"):
        """Only the DOFs an expression reads, as mappings ``{k-1: signal}`` (memory-lean).

        Parameters
        ----------
        displacement_dofs, velocity_dofs : iterable of int
            Measured DOFs (1-based) whose displacement / velocity is needed.

        Returns
        -------
        x, v : dict of int to ndarray, shape (n_samples,)
        """
        column = {dof: c for c, dof in enumerate(self.output_dofs)}
        x = {d - 1: self.displacement[:, column[d]] for d in displacement_dofs}
        v = {}
        velocity_dofs = list(velocity_dofs)
        if velocity_dofs:
            cols = [column[d] for d in velocity_dofs]
            if self.velocity is not None:
                vel = self.velocity[:, cols]
            else:
                vel = differentiate(self.displacement[:, cols], self.fs, velocity_method)
            v = {d - 1: vel[:, c] for c, d in enumerate(velocity_dofs)}
        return x, v

    def state_arrays(self, n_dofs: int | None = None, velocity_method: str = "fourth"):
        """DOF-major displacement and velocity arrays for term evaluation.

        Returns
        -------
        x, v : ndarray, shape (n_dofs, n_samples)
            Rows of unmeasured DOFs are NaN.
        """
        n_dofs = n_dofs or self.n_dofs
        x = np.full((n_dofs, self.n_samples), np.nan)
        v = np.full((n_dofs, self.n_samples), np.nan)
        vel = self.velocities(velocity_method)
        for col, dof in enumerate(self.output_dofs):
            if dof <= n_dofs:
                x[dof - 1] = self.displacement[:, col]
                v[dof - 1] = vel[:, col]
        return x, v
