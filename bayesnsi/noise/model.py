"""The sensor noise of a record: its level per channel and fresh draws of it (docs/method.md §11).

Everything that holds a model against "the noise the data carry" reads it from one
:class:`NoiseModel`, chosen once per record by :func:`noise_model`:

* :class:`PeriodScatterNoise` - two or more whole periods per realisation: whatever differs between
  the periods is noise, coloured or not. Draws combine the period deviations of the responses and
  the force jointly (:class:`~bayesnsi.noise.periodic.PeriodNoise`), so a force measured with noise
  of its own and the responses it drives keep their correlation.
* :class:`IntegratedSensorNoise` - responses integrated in time from accelerometers or velocity
  sensors with the loader's recipe kept (:class:`~bayesnsi.noise.integrated.AccelerationNoise`):
  white sensor noise integrated by exactly that recipe, displacement and velocity from one draw.
* :class:`WhiteSensorNoise` - otherwise: white noise at the level of high-order differences
  (:func:`~bayesnsi.noise.levels.white_noise_std`); measured velocities at the smaller of their
  differences level and their mismatch with the measured displacement below the lowest mode
  (:func:`velocity_noise_std`).

The noise replicates of the intervals, the adequacy yardstick and the band-by-band residual check
all draw from the same model; nothing else estimates sensor noise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

from .integrated import AccelerationNoise, acceleration_noise_of
from .levels import white_noise_std
from .periodic import PeriodNoise, period_noise

__all__ = [
    "IntegratedSensorNoise",
    "NoiseDraw",
    "NoiseModel",
    "PeriodScatterNoise",
    "WhiteSensorNoise",
    "noise_model",
    "noisy_copy",
    "velocity_noise_std",
]


class NoiseDraw(NamedTuple):
    """One draw of a record's noise, shaped as its fields (None: that field is not perturbed)."""

    displacement: np.ndarray
    velocity: np.ndarray | None
    force: np.ndarray | None


@runtime_checkable
class NoiseModel(Protocol):
    """The noise of one record: where the estimate came from, its level, and fresh draws of it."""

    @property
    def source(self) -> str:
        """Where the level comes from: "period scatter", "accelerometers (estimated)" (or declared, or velocity
        sensors) or "differences"."""
        ...

    def std(self, interior: bool = False) -> np.ndarray:
        """Noise std of each response channel, in the record's displacement field.

        Parameters
        ----------
        interior : bool
            Over the samples clear of an integration's edge error only (integrated records).

        Returns
        -------
        ndarray, shape (n_outputs,)
        """
        ...

    def draw(self, rng: np.random.Generator) -> NoiseDraw:
        """One fresh draw of the noise, shaped as the record.

        Parameters
        ----------
        rng : numpy.random.Generator

        Returns
        -------
        NoiseDraw
        """
        ...


@dataclass(frozen=True)
class PeriodScatterNoise:
    """Noise of a record of whole periods: its responses' and force's scatter between periods.

    Parameters
    ----------
    scatter : PeriodNoise
        Deviations of the displacement, velocity (when measured) and force columns, side by side.
    n_samples, n_outputs, n_velocities : int
        Record length and the widths of the displacement and velocity fields.
    """

    scatter: PeriodNoise
    n_samples: int
    n_outputs: int
    n_velocities: int
    source: str = "period scatter"

    def std(self, interior: bool = False) -> np.ndarray:
        """Scatter std of each displacement channel (``interior`` is irrelevant: no edges)."""
        return self.scatter.std[: self.n_outputs]

    def draw(self, rng: np.random.Generator) -> NoiseDraw:
        """A new random combination of the period deviations per period (responses and force jointly)."""
        e = self.scatter.draw(self.n_samples, rng)
        n_y, n_v = self.n_outputs, self.n_velocities
        return NoiseDraw(e[:, :n_y], e[:, n_y : n_y + n_v] if n_v else None, e[:, n_y + n_v :])


@dataclass(frozen=True)
class IntegratedSensorNoise:
    """White accelerometer (or velocity-sensor) noise integrated by the loader's recipe.

    Parameters
    ----------
    recipe : AccelerationNoise
        The sensors' white noise std and the integration recipe.
    n_samples : int
        Record length.
    """

    recipe: AccelerationNoise
    n_samples: int

    @property
    def source(self) -> str:
        """"accelerometers" or "velocity sensors", and whether their level was estimated or declared."""
        sensors = "accelerometers" if self.recipe.measured == "acceleration" else "velocity sensors"
        return f"{sensors} ({self.recipe.source})"

    def std(self, interior: bool = False) -> np.ndarray:
        """Std of the integrated noise per channel (over the interior only when asked)."""
        return self.recipe.std(self.n_samples, interior=interior)[0]

    def draw(self, rng: np.random.Generator) -> NoiseDraw:
        """White sensor noise integrated: displacement and velocity from one draw; the force is exact."""
        displacement, velocity = self.recipe.draw(self.n_samples, rng)
        return NoiseDraw(displacement, velocity, None)


@dataclass(frozen=True)
class WhiteSensorNoise:
    """White noise per channel: displacement (and measured velocity) sensors; the force is exact.

    Parameters
    ----------
    displacement_std : ndarray, shape (l,)
    velocity_std : ndarray, shape (l,) or None
        None when the record has no measured velocities.
    n_samples : int
    """

    displacement_std: np.ndarray
    velocity_std: np.ndarray | None
    n_samples: int
    source: str = "differences"

    def std(self, interior: bool = False) -> np.ndarray:
        """The displacement channels' std."""
        return self.displacement_std

    def draw(self, rng: np.random.Generator) -> NoiseDraw:
        """Independent Gaussian noise per sample and channel (displacement first, then velocity)."""
        shape = (self.n_samples, len(self.displacement_std))
        e_y = rng.standard_normal(shape) * self.displacement_std
        e_v = None if self.velocity_std is None else rng.standard_normal(shape) * self.velocity_std
        return NoiseDraw(e_y, e_v, None)


def noise_model(signals, lowest_hz: float = 0.0) -> NoiseModel:
    """The noise model of a record (module notes), built once per record and lowest mode.

    Parameters
    ----------
    signals : Signals
        The record.
    lowest_hz : float
        Lowest natural frequency of an identified model [Hz]: measured velocities' mismatch with the
        displacement is read below 0.8 times it (0: differences only). Only the white model uses it.

    Returns
    -------
    NoiseModel
        Memoised on the (read-only) Signals.
    """
    memo = vars(signals).setdefault("_noise_models", {})  # Signals hold read-only copies: once per record
    key = float(lowest_hz)
    if key not in memo:
        memo[key] = _build(signals, key)
    return memo[key]


def _build(signals, lowest_hz: float) -> NoiseModel:
    y = np.asarray(signals.displacement, dtype=float)
    v = None if signals.velocity is None else np.asarray(signals.velocity, dtype=float)
    f = np.asarray(signals.force, dtype=float)
    columns = [y] + ([] if v is None else [v]) + [f]
    scatter = period_noise(np.column_stack(columns), signals.period, signals.realisations)
    if scatter is not None:
        return PeriodScatterNoise(scatter, len(y), y.shape[1], 0 if v is None else v.shape[1])
    recipe = acceleration_noise_of(signals)
    if recipe is not None:
        return IntegratedSensorNoise(recipe, len(y))
    y_std = white_noise_std(y)
    v_std = None if v is None else velocity_noise_std(y, v, signals.fs, y_std, lowest_hz)
    return WhiteSensorNoise(y_std, v_std, len(y))


def noisy_copy(signals, noise: NoiseDraw):
    """``signals`` with one noise draw added to the fields it perturbs.

    Parameters
    ----------
    signals : Signals
    noise : NoiseDraw
        None fields leave that field as it is.

    Returns
    -------
    Signals
        A new record (the memoised noise model is not carried over).
    """
    changed = {}
    for field_name, added in zip(NoiseDraw._fields, noise):
        if added is not None:
            changed[field_name] = np.asarray(getattr(signals, field_name), dtype=float) + added
    return replace(signals, **changed)


def velocity_noise_std(displacement, velocity, fs: float, displacement_std, lowest_hz: float) -> np.ndarray:
    """Noise std of measured velocities: the smaller of two estimates that signal can only inflate.

    High-order differences (:func:`~bayesnsi.noise.levels.white_noise_std`) see the velocity's own
    broadband content as noise (a driven DOF's velocity is not small near Nyquist: 0.13 for a 2 %
    noise on the two-DOF chain's driven DOF). The mismatch with the measured displacement,
    R = V - jωX on Hann-windowed DFT lines below 0.8 x the lowest mode (where the displacement is
    precise and the derivative relation exact), has power σ_v² + ω² σ_x² per line once the
    window's own derivative is put back (d(wx)/dt = wv + w'x, so R + DFT(w'x) holds the noise
    alone); its mean minus the known displacement part estimates σ_v² there.

    Parameters
    ----------
    displacement, velocity : ndarray, shape (n_samples, n_channels)
        Measured displacements and velocities of the same DOFs.
    fs : float
        Sampling frequency [Hz].
    displacement_std : ndarray, shape (n_channels,)
        Noise std of the displacements.
    lowest_hz : float
        Lowest natural frequency of the identified model [Hz] (0: differences only).

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    x, v = np.asarray(displacement, dtype=float), np.asarray(velocity, dtype=float)
    by_differences = white_noise_std(v)
    n = len(v)
    lines = np.arange(5, int(0.8 * lowest_hz * n / fs) + 1)  # 5 bins clear of the window's DC leakage
    if len(lines) < 8:
        return by_differences
    window = np.hanning(n)
    omega = 2 * np.pi * np.fft.rfftfreq(n, 1.0 / fs)[lines]
    X = np.fft.rfft(window[:, None] * (x - x.mean(axis=0)), axis=0)[lines]
    V = np.fft.rfft(window[:, None] * (v - v.mean(axis=0)), axis=0)[lines]
    k = np.arange(n)
    slope = 0.5 * (2 * np.pi / (n - 1)) * np.sin(2 * np.pi * k / (n - 1)) * fs  # d/dt of np.hanning(n)
    W = np.fft.rfft(slope[:, None] * (x - x.mean(axis=0)), axis=0)[lines]
    power = np.mean(np.abs(V - 1j * omega[:, None] * X + W) ** 2, axis=0) / np.sum(window**2)
    by_mismatch = np.sqrt(np.maximum(power - np.mean(omega**2) * np.asarray(displacement_std) ** 2, 0.0))
    return np.minimum(by_differences, by_mismatch)
