"""The one data container: measured forces and responses with their DOF maps.

Array convention (used throughout bayesnsi): time signals are ``(n_samples, n_channels)``;
DOFs are numbered from 1 as in the paper; frequencies in Hz are named ``*_hz`` and angular
frequencies ``omega`` [rad/s].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ._sampled import real_array
from .exceptions import InputDataError, ShapeError

if TYPE_CHECKING:
    from .noise.integrated import AccelerationNoise

__all__ = ["Signals", "differentiate", "join_realisations", "MIN_FS", "MAX_FS", "MEASURED_QUANTITIES"]

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
    arr = real_array(values, name)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ShapeError(f"{name} must have shape (n_samples, n_channels), got shape {arr.shape}")
    if n_samples is not None and arr.shape[0] != n_samples:
        raise ShapeError(
            f"{name} has {arr.shape[0]} samples but the forces have {n_samples}; "
            "all channels must be sampled together - trim them to the same length"
        )
    if not np.isfinite(arr).all():
        bad = ~np.isfinite(arr)
        row, col = np.argwhere(bad)[0]
        raise InputDataError(
            f"{name} holds {int(bad.sum())} NaN/Inf values (first at sample {row}, channel {col}); "
            "remove or interpolate them, or select a clean segment"
        )
    if arr.shape[0] > 1:
        varies = (arr[:1000] != arr[0]).any(axis=0)  # most channels vary early: the whole record only where not
        if not varies.all():
            varies = (arr != arr[0]).any(axis=0)
        if not varies.all():
            raise InputDataError(
                f"{name} channel {int(np.argmin(varies))} is constant; a constant channel carries no "
                "dynamic information - remove it from the config"
            )
    arr.setflags(write=False)
    return arr


def _check_realisations(realisations, period, n_samples: int) -> int:
    """``realisations`` checked against the record: whole periods each, at least two, equal lengths."""
    if isinstance(realisations, bool) or not isinstance(realisations, (int, np.integer)) or realisations < 1:
        raise InputDataError(f"realisations must be a whole number >= 1, got {realisations!r}")
    realisations = int(realisations)
    if realisations == 1:
        return 1
    if period is None:
        raise InputDataError(
            f"realisations = {realisations} needs the period: give [data] period (samples per period), "
            "or Signals(period=...)"
        )
    if n_samples % realisations or (n_samples // realisations) % period:
        raise InputDataError(
            f"the record of {n_samples} samples does not split into {realisations} equal realisations of whole "
            f"periods of {period} samples; give a window of {realisations} x (a whole number of periods) after "
            "the dropped transient periods, or join records of equal length with join_realisations"
        )
    if n_samples // realisations // period < 2:
        raise InputDataError(
            f"each of the {realisations} realisations holds {n_samples // realisations // period} period(s) "
            "(after the dropped transient periods); the noise of a realisation comes from its period scatter: "
            "give at least two steady periods per realisation, or drop fewer transient periods"
        )
    return realisations


def join_realisations(records, drop: int = 0) -> Signals:
    """One record of several realisations of a periodic test (one Signals each), for joint estimation.

    Parameters
    ----------
    records : sequence of Signals
        One per realisation: the same ``period``, ``fs``, DOFs, names, ``measured``, length and
        velocity channels (measured or not in all).
    drop : int
        Leading (transient) periods left out of each realisation.

    Returns
    -------
    Signals
        The steady periods of the realisations one after the other, ``realisations = len(records)``.

    Raises
    ------
    InputDataError
        When the records differ in any of the above, or a realisation keeps fewer than two periods.
    """
    records = list(records)
    if not records or not all(isinstance(r, Signals) for r in records):
        raise InputDataError("join_realisations needs a non-empty sequence of Signals, one per realisation")
    first = records[0]
    if first.period is None:
        raise InputDataError("join_realisations needs periodic records: give each Signals its period")
    if isinstance(drop, bool) or not isinstance(drop, (int, np.integer)) or drop < 0:
        raise InputDataError(f"drop (leading transient periods) must be an integer >= 0, got {drop!r}")
    keys = ("period", "fs", "input_dofs", "output_dofs", "input_names", "output_names", "measured", "n_samples")
    for k, rec in enumerate(records[1:], start=2):
        differing = [key for key in keys if getattr(rec, key) != getattr(first, key)]
        if (rec.velocity is None) != (first.velocity is None):
            differing.append("velocity")
        if rec.realisations != 1:
            differing.append("realisations")
        if differing:
            raise InputDataError(
                f"realisation {k} differs from realisation 1 in {', '.join(differing)}; realisations of one test "
                "share the period, sampling, channels and length - cut them to the same whole periods"
            )
    start = int(drop) * first.period
    if start >= first.n_samples:
        raise InputDataError(f"dropping {drop} period(s) leaves nothing of records of {first.n_samples} samples")
    stack = lambda name: np.concatenate([getattr(r, name)[start:] for r in records])  # noqa: E731
    return Signals(
        force=stack("force"), displacement=stack("displacement"),
        velocity=None if first.velocity is None else stack("velocity"), fs=first.fs,
        input_dofs=first.input_dofs, output_dofs=first.output_dofs, input_names=first.input_names,
        output_names=first.output_names, period=first.period, measured=first.measured, realisations=len(records),
    )


def _as_dofs(name: str, dofs, n_channels: int) -> tuple[int, ...]:
    given = np.atleast_1d(np.asarray(dofs, dtype=object)).ravel()
    for d in given:
        integral = isinstance(d, (int, np.integer)) or (isinstance(d, (float, np.floating)) and float(d).is_integer())
        if isinstance(d, (bool, np.bool_)) or not integral:
            raise InputDataError(f"{name}: DOFs are whole numbers from 1, got {d!r} in {tuple(given)!r}")
    dofs = tuple(int(d) for d in given)
    if len(dofs) != n_channels:
        raise ShapeError(f"{name}: {len(dofs)} DOFs given for {n_channels} channels")
    if any(d < 1 for d in dofs):
        raise InputDataError(f"{name}: DOFs are numbered from 1, got {dofs}")
    if len(set(dofs)) != len(dofs):
        raise InputDataError(f"{name}: DOF repeated in {dofs}; map each DOF to one channel")
    return dofs


@dataclass(frozen=True, repr=False)
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
    realisations : int
        Number of realisations of a periodic test the record holds one after the other (new
        phases of the multisine each, the same length, each of whole steady-state periods, at
        least two; default 1). Each realisation's periods are averaged and its noise taken from
        its own period scatter; the frequency route stacks the lines of all of them
        (docs/method.md §11). Needs ``period``. :func:`join_realisations` builds such a record
        from one Signals per realisation.
    acceleration_noise : AccelerationNoise, optional
        With ``measured = "acceleration"`` (or ``"velocity"``, its ``measured`` the same) on a record
        integrated in time (not line by line on whole periods): the sensors' white noise std and the
        integration recipe, from which
        the noise replicates and the adequacy check integrate the noise the data carry
        (bayesnsi.noise.integrated; docs/method.md §11). None otherwise.
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
    realisations: int = 1
    acceleration_noise: AccelerationNoise | None = None

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
        noise = self.acceleration_noise
        if noise is not None and len(getattr(noise, "acceleration_std", ())) != self.displacement.shape[1]:
            raise ShapeError("acceleration_noise must give one noise std per response channel")
        set_("realisations", _check_realisations(self.realisations, self.period, len(force)))

    def __repr__(self) -> str:
        from ._repr import compact_repr

        extra = {"period": self.period} if self.period is not None else {}
        if self.realisations > 1:
            extra["realisations"] = self.realisations
        return compact_repr(
            self, n_samples=self.n_samples, fs=self.fs, inputs=dict(zip(self.input_names, self.input_dofs)),
            outputs=dict(zip(self.output_names, self.output_dofs)), measured=self.measured,
            velocity="measured" if self.velocity is not None else "derived", **extra,
        )

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
            measured=self.measured,
            acceleration_noise=self.acceleration_noise,
            **self._segment_period(start, stop),
        )

    def _segment_period(self, start: int, stop: int) -> dict:
        """``period`` and ``realisations`` of samples ``start:stop``: the realisations it holds whole,
        one when inside one realisation, not periodic when it crosses a realisation boundary elsewhere."""
        if self.period is None or stop - start < self.period:
            return {"period": None}
        length = self.n_samples // self.realisations
        if self.realisations > 1 and start // length != (stop - 1) // length:
            if start % length or stop % length:
                return {"period": None}
            return {"period": self.period, "realisations": (stop - start) // length}
        return {"period": self.period}

    def realisation_records(self) -> list[Signals]:
        """The record of each realisation, as Signals of one realisation (a list of one without several).

        Returns
        -------
        list of Signals
            ``realisations`` records of ``n_samples / realisations`` samples each, in order.
        """
        if self.realisations == 1:
            return [self]
        length = self.n_samples // self.realisations
        return [self.segment(r * length, (r + 1) * length) for r in range(self.realisations)]

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
