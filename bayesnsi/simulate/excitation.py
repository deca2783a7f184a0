"""Band-limited random excitation and its continuous-time (fine-grid) interpolation.

docs/method.md §10: a force held constant between samples (zero-order hold) biases the NSI
coefficients (|Im/Re| ≈ 0.15) and a first-order hold by ≈ +1 %; only a band-limited force,
i.e. the trigonometric (FFT zero-padded, periodic sinc) interpolation of its samples, is
unbiased. Every simulated force is therefore carried on two grids: the coarse samples the
identification sees and the fine grid the integrator reads, with ``fine[::oversample]``
equal to the coarse samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError, ShapeError

__all__ = ["Excitation", "band_limited_gaussian", "from_samples", "fft_interpolate"]


@dataclass(frozen=True, eq=False)
class Excitation:
    """A band-limited signal on the measurement grid and on a fine integration grid.

    Attributes
    ----------
    samples : ndarray, shape (n_samples, n_channels)
        The signal at the sampling frequency ``fs`` (what a data file holds), read-only.
    fine : ndarray, shape (n_samples * oversample, n_channels)
        Its trigonometric interpolation at ``fs * oversample``; ``fine[::oversample]``
        equals ``samples`` to rounding. Read-only.
    fs : float
        Sampling frequency of ``samples`` [Hz].
    oversample : int
        Ratio of the fine to the coarse sampling frequency.
    band_hz : (float, float) or None
        Frequency band kept [Hz]; None for the full band 0 .. fs/2.
    """

    samples: np.ndarray
    fine: np.ndarray
    fs: float
    oversample: int
    band_hz: tuple[float, float] | None = None

    @property
    def fs_fine(self) -> float:
        """Sampling frequency of the fine grid [Hz]."""
        return self.fs * self.oversample

    @property
    def n_samples(self) -> int:
        """Number of coarse samples."""
        return self.samples.shape[0]

    @property
    def rms(self) -> np.ndarray:
        """Root mean square of each channel of the coarse samples, shape (n_channels,)."""
        return np.sqrt(np.mean(self.samples**2, axis=0))

    def scaled(self, factor: float) -> Excitation:
        """The same excitation multiplied by ``factor`` (e.g. ``-m`` for an inertial force)."""
        return Excitation(
            samples=_readonly(self.samples * factor),
            fine=_readonly(self.fine * factor),
            fs=self.fs,
            oversample=self.oversample,
            band_hz=self.band_hz,
        )


def band_limited_gaussian(
    n_samples: int,
    fs: float,
    rms,
    rng=None,
    oversample: int = 8,
    band_hz=None,
    n_channels: int = 1,
) -> Excitation:
    """Gaussian random signal, optionally band-limited, with its fine-grid interpolation.

    Parameters
    ----------
    n_samples : int
        Number of samples at ``fs``.
    fs : float
        Sampling frequency [Hz].
    rms : float or array_like, shape (n_channels,)
        Root mean square of each channel of the coarse samples (exact, not only expected),
        in the signal's unit (N for a force, m/s² for a table acceleration).
    rng : int, numpy.random.Generator or None
        Source of randomness, passed to :func:`numpy.random.default_rng`.
    oversample : int
        Ratio of the fine (integration) grid to ``fs``; positive integer.
    band_hz : (float, float), optional
        Keep only the FFT bins with ``lo <= f <= hi`` [Hz] (the DC bin is removed whenever
        ``lo > 0``). None keeps the white sequence unchanged (iid Gaussian samples).
    n_channels : int
        Number of independent channels.

    Returns
    -------
    Excitation

    Notes
    -----
    White samples ``e ~ N(0, 1)`` are drawn from ``rng``; if a band is given their FFT is
    zeroed outside it; the result is scaled to the requested rms and interpolated by
    :func:`fft_interpolate` (docs/method.md §10: a band-limited force, never a held one). The signal is
    periodic with period ``n_samples / fs``.

    Examples
    --------
    >>> exc = band_limited_gaussian(1000, 100.0, rms=10.0, rng=0, oversample=4)
    >>> exc.samples.shape, exc.fine.shape
    ((1000, 1), (4000, 1))
    >>> bool(np.allclose(exc.fine[::4], exc.samples))
    True
    """
    n_samples = _positive_int("n_samples", n_samples, minimum=2)
    n_channels = _positive_int("n_channels", n_channels)
    fs = _positive_float("fs", fs)
    rms = np.broadcast_to(np.asarray(rms, dtype=float), (n_channels,))
    if np.any(~np.isfinite(rms) | (rms < 0)):
        raise InputDataError(f"rms must be non-negative and finite, got {rms.tolist()}")
    generator = np.random.default_rng(rng)
    white = generator.standard_normal((n_samples, n_channels))
    band = None
    if band_hz is not None:
        band = _check_band(band_hz, fs)
        spectrum = np.fft.rfft(white, axis=0)
        freqs = np.fft.rfftfreq(n_samples, 1.0 / fs)
        spectrum[(freqs < band[0]) | (freqs > band[1])] = 0.0
        if not np.any(spectrum):
            raise InputDataError(
                f"band {band} Hz holds no FFT bin of a {n_samples}-sample record at {fs} Hz "
                f"(bin spacing {fs / n_samples:g} Hz); widen the band or lengthen the record"
            )
        white = np.fft.irfft(spectrum, n_samples, axis=0)
    current = np.sqrt(np.mean(white**2, axis=0))
    samples = white * (rms / current)
    return from_samples(samples, fs, oversample, band_hz=band)


def from_samples(samples, fs: float, oversample: int, band_hz=None) -> Excitation:
    """Excitation from given coarse samples (e.g. a measured table acceleration).

    Parameters
    ----------
    samples : array_like, shape (n_samples,) or (n_samples, n_channels)
        The signal at ``fs``.
    fs : float
        Sampling frequency [Hz].
    oversample : int
        Ratio of the fine grid to ``fs``.
    band_hz : (float, float), optional
        Recorded as metadata only; the samples are not filtered.

    Returns
    -------
    Excitation
        ``fine`` is the trigonometric interpolation of ``samples`` (:func:`fft_interpolate`);
        note that it treats the record as periodic, so a record whose ends do not match
        rings near its ends.
    """
    arr = np.array(samples, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] < 2:
        raise ShapeError(f"samples must have shape (n_samples, n_channels) with n_samples >= 2, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputDataError("samples hold NaN or Inf values; clean the record first")
    fs = _positive_float("fs", fs)
    oversample = _positive_int("oversample", oversample)
    band = None if band_hz is None else _check_band(band_hz, fs)
    fine = fft_interpolate(arr, oversample)
    return Excitation(_readonly(arr), _readonly(fine), fs, oversample, band)


def fft_interpolate(samples, oversample: int) -> np.ndarray:
    """Trigonometric (FFT zero-padded) interpolation along axis 0.

    Parameters
    ----------
    samples : array_like, shape (n_samples, ...)
        One period of a band-limited periodic signal.
    oversample : int
        Interpolation factor k.

    Returns
    -------
    ndarray, shape (n_samples * k, ...)
        The unique trigonometric polynomial of degree < n/2 through the samples (for even
        n the Nyquist bin is split equally between ±fs/2, which keeps the interpolant real
        and makes ``out[::k] == samples`` to rounding).
    """
    x = np.asarray(samples, dtype=float)
    k = _positive_int("oversample", oversample)
    if k == 1:
        return x.copy()
    n = x.shape[0]
    spectrum = np.fft.rfft(x, axis=0)
    padded = np.zeros((n * k // 2 + 1,) + x.shape[1:], dtype=complex)
    padded[: spectrum.shape[0]] = spectrum
    if n % 2 == 0:
        padded[n // 2] *= 0.5
    return np.fft.irfft(padded, n * k, axis=0) * k


def _check_band(band_hz, fs: float) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in band_hz)
    except (TypeError, ValueError):
        raise InputDataError(f"band_hz must be a pair (low, high) in Hz, got {band_hz!r}") from None
    if not (0 <= lo < hi) or not np.isfinite(hi):
        raise InputDataError(f"band_hz must satisfy 0 <= low < high, got {band_hz!r}")
    if lo > fs / 2:
        raise InputDataError(f"band_hz low edge {lo} Hz is above the Nyquist frequency {fs / 2} Hz")
    return lo, min(hi, fs / 2)


def _positive_int(name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise InputDataError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _positive_float(name: str, value) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise InputDataError(f"{name} must be a positive number, got {value!r}")
    return value


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.ascontiguousarray(arr)
    arr.setflags(write=False)
    return arr
