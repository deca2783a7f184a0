"""The accelerometer noise of integrated accelerations, and how it reaches displacement and velocity.

A record measured by accelerometers and integrated on load (``[data] integrate`` on a record
without whole periods, :func:`bayesnsi.preprocess.integrate_acceleration`) holds the sensor's
white noise integrated through the band window: in displacement its spectrum is
``σ_a² (2/fs) |W(f)|² / (2πf)⁴``, concentrated near the band's lower edge, where high-order
differences of the displacement see almost nothing of it (the replicates added ~0 noise). The
noise is white, and measurable, only on the acceleration before integration. The loader keeps
its std per channel (estimated there, or declared) with the integration recipe - the same
function, band, window and decimation - as :attr:`Signals.acceleration_noise
<bayesnsi.signals.Signals>`; the noise replicates and the adequacy check (docs/method.md §11)
then integrate fresh white acceleration noise through exactly that routine: integration is
linear, so its displacement and velocity are the noise the data carry, consistent between them.
Velocity sensors (a laser vibrometer) integrated once on load are described the same way
(``measured = "velocity"``): their white noise reaches the displacement as ``|W(f)|²/(2πf)²``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._resample import decimate as _decimate_signals
from ..exceptions import InputDataError
from ..preprocess import INTEGRATED_QUANTITIES, INTEGRATION_METHODS, integrate_measured

__all__ = ["AccelerationNoise", "NOISE_SOURCES", "acceleration_noise_of", "edge_samples"]

NOISE_SOURCES = ("estimated", "declared")
"""Where :attr:`AccelerationNoise.acceleration_std` comes from."""

_UNIT_DRAWS = 32  # unit-noise records averaged for the integrated noise std (about 1 % on the std)


@dataclass(frozen=True)
class AccelerationNoise:
    """White accelerometer noise per channel and the integration recipe that made the Signals.

    Parameters
    ----------
    acceleration_std : tuple of float
        Noise std of each response channel as its sensor measured it (acceleration, or velocity
        for ``measured = "velocity"``; in the file's unit times ``[data] scale``), in the order of
        the Signals' output channels.
    fs : float
        Sampling frequency the accelerations were integrated at [Hz] (the file's, before ``decimate``).
    band_hz : (float, float)
        Integration band (:func:`bayesnsi.preprocess.integrate_acceleration`).
    method : {"frequency", "time"}
        Integration method.
    taper : float
        Relative transition width of the band window (frequency method).
    filter_order, detrend_order : int
        Butterworth order and detrending order (time method).
    decimate : int
        Down-sampling factor applied after integration (``[data] decimate``).
    source : {"estimated", "declared"}
        Estimated from the measured accelerations, or declared in the config
        (``[data] integrate = { ..., noise_std = ... }``).
    trim : int
        Samples (of the Signals) dropped at each end after integration (``trim_edges``; 0: none).
    measured : {"acceleration", "velocity"}
        What the sensors measured: integrated twice (accelerometers) or once (velocity sensors).
    """

    acceleration_std: tuple[float, ...]
    fs: float
    band_hz: tuple[float, float]
    method: str = "frequency"
    taper: float = 0.5
    filter_order: int = 4
    detrend_order: int = 2
    decimate: int = 1
    source: str = "estimated"
    trim: int = 0
    measured: str = "acceleration"

    def __post_init__(self):
        std = tuple(float(s) for s in np.atleast_1d(self.acceleration_std))
        if not std or not all(np.isfinite(s) and s >= 0 for s in std):
            raise InputDataError(f"acceleration_std must be finite numbers >= 0, got {self.acceleration_std!r}")
        object.__setattr__(self, "acceleration_std", std)
        object.__setattr__(self, "band_hz", (float(self.band_hz[0]), float(self.band_hz[1])))
        object.__setattr__(self, "fs", float(self.fs))
        if self.method not in INTEGRATION_METHODS:
            raise InputDataError(f"unknown integration method {self.method!r}; use one of {INTEGRATION_METHODS}")
        if self.measured not in INTEGRATED_QUANTITIES:
            raise InputDataError(f"measured must be one of {INTEGRATED_QUANTITIES}, got {self.measured!r}")
        if self.source not in NOISE_SOURCES:
            raise InputDataError(f"source must be one of {NOISE_SOURCES}, got {self.source!r}")
        if int(self.decimate) < 1:
            raise InputDataError(f"decimate must be a positive whole number, got {self.decimate!r}")

    @property
    def edge_samples(self) -> int:
        """Samples at each end of the Signals that carry the integration's edge error.

        A finite record is integrated as if the acceleration were zero outside it, so for about two
        decay times of the band-limited integrator, ``2 / (taper f_lo)`` seconds (the frequency
        method's default zero padding; ``taper`` at least 0.25, also for the time method's
        filters), the displacement misses the motion before the start and after the end (a record
        that ends moving: the true model's residual over the two edges was 2.5-8.4x that of the
        interior on 30 seeds of ``benchmarks/accelerometer_intervals.py``).

        Returns
        -------
        int
        """
        return edge_samples(self.band_hz, self.taper, self.signals_fs)

    def interior(self, n_samples: int) -> slice:
        """The samples of a record of ``n_samples`` clear of both edges (all of them when that leaves under half).

        Parameters
        ----------
        n_samples : int
            Samples of the Signals.

        Returns
        -------
        slice
        """
        edge = 0 if self.trim else self.edge_samples  # trimmed: the edges are gone already
        return slice(edge, n_samples - edge) if n_samples > 4 * edge else slice(0, n_samples)

    def edge_ratio(self, residual) -> float | None:
        """Rms of ``residual`` over both edges over its rms over :meth:`interior` (largest channel).

        Parameters
        ----------
        residual : array_like, shape (n_samples, n_channels)
            E.g. a model's open-loop residual on the Signals.

        Returns
        -------
        float or None
            None when the edges were trimmed or the record is too short to have an interior.
        """
        r = np.asarray(residual, dtype=float).reshape(len(residual), -1)
        inner = self.interior(len(r))
        if self.trim or inner.start == 0:
            return None
        edges = np.concatenate([r[: inner.start], r[inner.stop :]])
        inside = np.sqrt(np.mean(r[inner] ** 2, axis=0))
        return float(np.max(np.sqrt(np.mean(edges**2, axis=0)) / np.where(inside > 0, inside, np.finfo(float).tiny)))

    @property
    def signals_fs(self) -> float:
        """Sampling frequency of the Signals it describes [Hz]: ``fs / decimate``."""
        return self.fs / int(self.decimate)

    def integrate(self, acceleration) -> tuple[np.ndarray, np.ndarray]:
        """The recipe applied to sensor signals sampled at :attr:`fs`: velocity and displacement.

        Parameters
        ----------
        acceleration : array_like, shape (n_samples, n_channels)
            Accelerations (velocities for ``measured = "velocity"``) at the file's rate.

        Returns
        -------
        velocity, displacement : ndarray, shape (ceil(n_samples / decimate), n_channels)
            Integrated as the loader integrated the data, then decimated.
        """
        v, x = integrate_measured(acceleration, self.measured, self.fs, self.band_hz, self.method, taper=self.taper,
                                  filter_order=self.filter_order, detrend_order=self.detrend_order)
        q = int(self.decimate)
        if q > 1:
            v, x = _decimate_signals(v, q), _decimate_signals(x, q)
        return v, x

    def draw(self, n_samples: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Displacement and velocity noise of one replicate: white sensor noise, integrated.

        Parameters
        ----------
        n_samples : int
            Samples of the Signals (after decimation).
        rng : numpy.random.Generator
            Source of the white sensor noise.

        Returns
        -------
        displacement, velocity : ndarray, shape (n_samples, n_channels)
            One draw each, from the same acceleration noise.
        """
        keep = slice(int(self.trim), int(self.trim) + int(n_samples))
        n_raw = (int(n_samples) + 2 * int(self.trim)) * int(self.decimate)
        white = rng.standard_normal((n_raw, len(self.acceleration_std))) * np.asarray(self.acceleration_std)
        v, x = self.integrate(white)
        return x[keep], v[keep]

    def std(self, n_samples: int, interior: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Std of the integrated noise per channel over a record of ``n_samples`` samples.

        The mean square over the record of white unit noise integrated by the recipe (32 records of
        a fixed seed: about 1 % on the std), times :attr:`acceleration_std`.

        Parameters
        ----------
        n_samples : int
            Samples of the Signals (after decimation).
        interior : bool
            Over :meth:`interior` only (the adequacy check's residual leaves the edges out).

        Returns
        -------
        displacement_std, velocity_std : ndarray, shape (n_channels,)
        """
        unit_x, unit_v = _unit_std(self, int(n_samples), bool(interior))
        scale = np.asarray(self.acceleration_std)
        return unit_x * scale, unit_v * scale


@lru_cache(maxsize=16)
def _unit_std(noise: AccelerationNoise, n_samples: int, interior: bool) -> tuple[float, float]:
    """Rms displacement and velocity of unit white sensor noise through ``noise``'s recipe."""
    rng = np.random.default_rng(np.random.SeedSequence([n_samples, 20]))
    n_raw = (n_samples + 2 * int(noise.trim)) * int(noise.decimate)
    v, x = noise.integrate(rng.standard_normal((n_raw, _UNIT_DRAWS)))
    inner = noise.interior(n_samples) if interior else slice(0, n_samples)
    keep = slice(inner.start + int(noise.trim), inner.stop + int(noise.trim))
    return float(np.sqrt(np.mean(x[keep] ** 2))), float(np.sqrt(np.mean(v[keep] ** 2)))


def edge_samples(band_hz, taper: float, fs: float) -> int:
    """Samples at each end of a record integrated in ``band_hz`` that carry the edge error (module notes).

    Parameters
    ----------
    band_hz : (float, float)
        Integration band.
    taper : float
        Relative transition width of the band window (at least 0.25 is used).
    fs : float
        Sampling frequency of the integrated record [Hz] (after any decimation).

    Returns
    -------
    int
        ``ceil(2 / (taper f_lo) fs)``: two decay times of the band-limited integrator.
    """
    return int(np.ceil(2.0 / (max(float(taper), 0.25) * float(band_hz[0])) * float(fs)))


def acceleration_noise_of(signals) -> AccelerationNoise | None:
    """The integrated sensor noise of ``signals`` (accelerometers, velocity sensors) when it describes them, else None.

    Parameters
    ----------
    signals : Signals
        Any signals.

    Returns
    -------
    AccelerationNoise or None
        None unless the signals were integrated from what ``noise.measured`` names with a recipe kept, at the rate
        the recipe gives (a resampled copy, e.g. ``identify``'s upsampled grid, is not described).
    """
    noise = signals.acceleration_noise
    if noise is None or signals.measured != noise.measured:
        return None
    width = np.asarray(signals.displacement).reshape(len(signals.displacement), -1).shape[1]
    if len(noise.acceleration_std) != width or abs(noise.signals_fs - float(signals.fs)) > 1e-9 * noise.signals_fs:
        return None
    return noise
