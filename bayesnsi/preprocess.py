"""Sensor conversions before identification: integration, band filtering, detrending, decimation.

numpy/scipy only. Every function returns new arrays (or new :class:`~bayesnsi.signals.Signals`)
and never modifies its input. Array convention of bayesnsi: ``(n_samples, n_channels)``; a 1-D
array is treated as one channel and returned 1-D.

- :func:`integrate_acceleration`: accelerometer -> (velocity, displacement), by frequency-domain
  division by jω / (jω)² with a zero-phase band window, or by the trapezoid rule with polynomial
  detrending and a zero-phase Butterworth high-pass.
- :func:`band_filter`: the *same* zero-phase band weighting applied to other channels (the
  forces), so that input and output see one filter and the in-band input-output relation is kept.
- :func:`detrend`, :func:`decimate`, :func:`select_segment`: on arrays or on Signals.

The measured-accelerations path is used by :func:`bayesnsi.io.load_signals` when the config
has ``[data] accelerations`` and ``[data] integrate`` (see :class:`bayesnsi.io.DataSpec`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import fft as _fft
from scipy import signal as _signal
from scipy.integrate import cumulative_trapezoid

from .exceptions import InputDataError
from .signals import Signals

__all__ = [
    "INTEGRATION_METHODS",
    "integrate_acceleration",
    "band_filter",
    "band_window",
    "detrend",
    "decimate",
    "upsample",
    "select_segment",
]

INTEGRATION_METHODS = ("frequency", "time")
"""Methods of :func:`integrate_acceleration`."""


# ---------------------------------------------------------------------------------------------
# integration and band filtering


def band_window(freqs_hz, band_hz, fs: float, taper: float = 0.5) -> np.ndarray:
    """The real, zero-phase band weighting W(f) of the frequency-domain method.

    Parameters
    ----------
    freqs_hz : array_like
        Frequencies [Hz] (non-negative; the window is even in f).
    band_hz : (float, float)
        Pass band ``(f_lo, f_hi)`` [Hz], ``0 <= f_lo < f_hi``. ``f_lo = 0``: no high-pass;
        ``f_hi >= fs/2``: no low-pass.
    fs : float
        Sampling frequency [Hz].
    taper : float
        Relative width of the raised-cosine transitions, ``0 <= taper < 1``.

    Returns
    -------
    ndarray
        W(f): 0 for ``f <= f_lo (1 - taper)``; ``(1 - cos(π (f - f_lo(1-taper)) / (taper f_lo))) / 2``
        rising to 1 at ``f_lo``; exactly 1 on ``[f_lo, f_hi]``; a raised cosine falling from 1 at
        ``f_hi`` to 0 at ``min(f_hi (1 + taper), fs/2)``; 0 above. Real and non-negative, so the
        filter has zero phase. ``taper = 0`` is a brick wall (long ringing in time).
    """
    f = np.abs(np.asarray(freqs_hz, dtype=float))
    lo, hi = _check_band(band_hz, fs, allow_dc=True)
    _check_taper(taper)
    w = np.ones_like(f)
    if lo > 0:
        lo0 = lo * (1.0 - taper)
        w[f <= lo0] = 0.0
        if taper > 0:
            rise = (f > lo0) & (f < lo)
            w[rise] = 0.5 * (1.0 - np.cos(np.pi * (f[rise] - lo0) / (lo - lo0)))
        else:
            w[f < lo] = 0.0
    if hi < fs / 2:
        hi1 = min(hi * (1.0 + taper), fs / 2)
        if hi1 > hi:
            fall = (f > hi) & (f < hi1)
            w[fall] *= 0.5 * (1.0 + np.cos(np.pi * (f[fall] - hi) / (hi1 - hi)))
        w[f >= hi1] = 0.0
    return w


def integrate_acceleration(
    acc,
    fs: float,
    band_hz: tuple[float, float],
    method: str = "frequency",
    *,
    taper: float = 0.5,
    pad_s: float | None = None,
    filter_order: int = 4,
    detrend_order: int = 2,
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement from measured acceleration.

    Parameters
    ----------
    acc : array_like, shape (n_samples,) or (n_samples, n_channels)
        Accelerations [m/s²] (any unit u; the results are in u·s and u·s²).
    fs : float
        Sampling frequency [Hz].
    band_hz : (float, float)
        ``(f_lo, f_hi)`` [Hz] with ``0 < f_lo < f_hi``. The high-pass at ``f_lo`` removes the
        drift that integration turns offsets, sensor drift and low-frequency noise into
        (noise is amplified by 1/ω and 1/ω²): **content below f_lo is lost**, whether it is
        drift or true motion (e.g. a quasi-static or rigid-body displacement). ``f_hi`` is an
        optional low-pass (give ``f_hi >= fs/2`` for none). Choose ``f_lo`` below the lowest
        mode, by at least a factor 2 for the frequency method with the default taper.
    method : {"frequency", "time"}
        "frequency" (default): FFT of the (mean-removed, zero-padded) record multiplied by
        ``W(f)/(jω)`` and ``W(f)/(jω)²`` with the window of :func:`band_window`. W is real, so
        the result has **zero phase error**; the gain is **exact on [f_lo, f_hi]**, follows the
        raised cosine on ``[f_lo(1 - taper), f_lo]`` (and above f_hi) and is 0 below
        ``f_lo(1 - taper)``.
        "time": trapezoid rule, polynomial detrend of order ``detrend_order`` after each
        integration, and a zero-phase Butterworth high-pass of order ``filter_order`` (applied
        forward-backward, twice, to both outputs so they share one filter). The trapezoid
        integrator has exact phase but gain ``(ωΔt/2)/tan(ωΔt/2) ≈ 1 - (ωΔt)²/12`` per
        integration (-1.9 % at ωΔt = 0.47, i.e. 7.5 Hz at 100 Hz); the high-pass gain is
        ``(1 + (f_lo/f)^(2N))^-2`` (-12 dB at f_lo, -0.8 % at 2 f_lo for N = 4), zero phase;
        the optional low-pass (same order, forward-backward) has gain ``(1 + (f/f_hi)^(2N))^-1``.
    taper : float
        Relative transition width of the frequency window (see :func:`band_window`).
    pad_s : float, optional
        Zeros appended before the FFT [s] (frequency method), to keep the circular
        convolution from wrapping the end of the record onto its start. Default
        ``2 / (taper f_lo)`` (the decay time of the band-limited integrator's response),
        at least ``2 / f_lo``.
    filter_order : int
        Butterworth order N (time method).
    detrend_order : int
        Polynomial order removed after each integration (time method).

    Returns
    -------
    velocity, displacement : ndarray
        Same shape as ``acc``; new arrays.

    Raises
    ------
    InputDataError
        For a bad band, method or shape, NaN/Inf values, or fewer than 8 samples.

    Notes
    -----
    Limits. (1) A finite record: outside it the acceleration is taken as zero (frequency
    method) or the filter's start-up transient acts (time method), so the first and last
    ``~1/f_lo`` seconds carry edge errors; exclude them from estimation if they matter (a
    record that starts from rest has no error at its start with the frequency method).
    (2) Below ``f_lo`` nothing is recovered. (3) Measurement noise of the accelerometer is
    integrated as well: its displacement share grows like 1/f² towards f_lo. (4) Filter the
    forces with the same band (:func:`band_filter`) before identification, so that input and
    output carry the same filter; nonlinear terms evaluated on filtered responses are then an
    approximation, good when the filter removes little response energy.
    """
    a = _as_columns(acc, "acceleration")
    fs = _check_fs(fs)
    lo, hi = _check_band(band_hz, fs, allow_dc=False)
    if method not in INTEGRATION_METHODS:
        raise InputDataError(f"unknown integration method {method!r}; use one of {INTEGRATION_METHODS}")
    if method == "frequency":
        _check_taper(taper)
        velocity, displacement = _frequency_filter(a.array, fs, (lo, hi), taper, pad_s, powers=(1, 2))
    else:
        velocity, displacement = _time_integrate(a.array, fs, (lo, hi), filter_order, detrend_order)
    return a.restore(velocity), a.restore(displacement)


def band_filter(
    signal,
    fs: float,
    band_hz: tuple[float, float],
    method: str = "frequency",
    *,
    taper: float = 0.5,
    pad_s: float | None = None,
    filter_order: int = 4,
) -> np.ndarray:
    """Apply the band weighting of :func:`integrate_acceleration` without integrating.

    Use it on the forces when the responses come from :func:`integrate_acceleration` with the
    same arguments: both then carry the same zero-phase gain, so the in-band input-output
    relation is unchanged.

    Parameters
    ----------
    signal : array_like, shape (n_samples,) or (n_samples, n_channels)
    fs : float
    band_hz : (float, float)
        As in :func:`integrate_acceleration`, but ``f_lo = 0`` (no high-pass) is allowed.
    method : {"frequency", "time"}
        "frequency": multiply the spectrum by W(f) (:func:`band_window`). "time": the
        Butterworth high-pass applied forward-backward twice (gain ``(1 + (f_lo/f)^(2N))^-2``)
        and the optional low-pass forward-backward once, as the time integration applies them.
    taper, pad_s, filter_order
        As in :func:`integrate_acceleration`.

    Returns
    -------
    ndarray
        Same shape as ``signal``; a new array. The mean is removed when ``f_lo > 0``.
    """
    s = _as_columns(signal, "signal")
    fs = _check_fs(fs)
    lo, hi = _check_band(band_hz, fs, allow_dc=True)
    if method not in INTEGRATION_METHODS:
        raise InputDataError(f"unknown filter method {method!r}; use one of {INTEGRATION_METHODS}")
    if method == "frequency":
        _check_taper(taper)
        (out,) = _frequency_filter(s.array, fs, (lo, hi), taper, pad_s, powers=(0,))
    else:
        out = _butter_band(s.array, fs, (lo, hi), filter_order)
    return s.restore(out)


def _frequency_filter(a, fs, band, taper, pad_s, powers):
    n = a.shape[0]
    lo = band[0]
    if pad_s is None:
        # about two decay times of the band-limited integrator (transition width taper*f)
        edge = lo if lo > 0 else (band[1] if band[1] < fs / 2 else 0.0)
        pad_s = 2.0 / (edge * (taper if taper > 0 else 1.0)) if edge > 0 else 0.0
    if not (math.isfinite(pad_s) and pad_s >= 0):
        raise InputDataError(f"pad_s must be a non-negative number of seconds, got {pad_s!r}")
    n_fft = _fft.next_fast_len(n + int(math.ceil(pad_s * fs)), real=True)
    centred = a - a.mean(axis=0) if lo > 0 else a
    spectrum = _fft.rfft(centred, n=n_fft, axis=0)
    freqs = _fft.rfftfreq(n_fft, 1.0 / fs)
    window = band_window(freqs, band, fs, taper)
    out = []
    jw = 2j * np.pi * freqs
    for power in powers:
        gain = window.astype(complex)
        if power:
            nonzero = window > 0
            gain[nonzero] = window[nonzero] / jw[nonzero] ** power
            gain[~nonzero] = 0.0
        out.append(_fft.irfft(spectrum * gain[:, None], n=n_fft, axis=0)[:n])
    return out


def _time_integrate(a, fs, band, order, detrend_order):
    dt = 1.0 / fs
    _check_int(order, "filter_order", 1)
    _check_int(detrend_order, "detrend_order", 0)
    high = _signal.butter(order, band[0], btype="highpass", fs=fs, output="sos")
    v0 = _poly_detrend(cumulative_trapezoid(a, dx=dt, axis=0, initial=0.0), detrend_order)
    v1 = _filtfilt(high, v0)
    x = _filtfilt(high, _poly_detrend(cumulative_trapezoid(v1, dx=dt, axis=0, initial=0.0), detrend_order))
    v = _filtfilt(high, v1)
    if band[1] < fs / 2:
        low = _signal.butter(order, band[1], btype="lowpass", fs=fs, output="sos")
        v, x = _filtfilt(low, v), _filtfilt(low, x)
    return v, x


def _butter_band(s, fs, band, order):
    _check_int(order, "filter_order", 1)
    out = np.array(s, dtype=float, copy=True)
    if band[0] > 0:
        high = _signal.butter(order, band[0], btype="highpass", fs=fs, output="sos")
        out = _filtfilt(high, _filtfilt(high, out - out.mean(axis=0)))
    if band[1] < fs / 2:
        low = _signal.butter(order, band[1], btype="lowpass", fs=fs, output="sos")
        out = _filtfilt(low, out)
    return out


def _filtfilt(sos, x):
    # forward-backward (zero phase), scipy's default odd-extension padding at the ends
    return _signal.sosfiltfilt(sos, x, axis=0)


# ---------------------------------------------------------------------------------------------
# detrend, decimate, segments


def detrend(signals, order: int = 1):
    """Remove a least-squares polynomial trend from every channel.

    Parameters
    ----------
    signals : Signals or array_like, shape (n_samples,) or (n_samples, n_channels)
        With Signals: forces, displacements and (if present) velocities are detrended, each
        channel independently. This breaks the exact relation v = dx/dt when a trend is removed
        from both; for order 0 (the mean) it does not.
    order : int
        Polynomial order (0: mean, 1: line, ...). The fit uses a scaled time axis on [-1, 1]
        (well conditioned up to order ~20).

    Returns
    -------
    Signals or ndarray
        Same type and shape as the input; new arrays.
    """
    _check_int(order, "order", 0)
    if isinstance(signals, Signals):
        return replace(
            signals,
            force=_poly_detrend(np.asarray(signals.force), order),
            displacement=_poly_detrend(np.asarray(signals.displacement), order),
            velocity=None if signals.velocity is None else _poly_detrend(np.asarray(signals.velocity), order),
        )
    s = _as_columns(signals, "signal")
    return s.restore(_poly_detrend(s.array, order))


def decimate(signals, factor: int):
    """Anti-aliased down-sampling by an integer factor (zero-phase FIR).

    :func:`scipy.signal.decimate` with ``ftype="fir", zero_phase=True``: a Hamming-windowed
    sinc of ``20·factor + 1`` taps with cut-off at the new Nyquist frequency, applied
    without delay; output sample j is at the time of input sample ``j·factor``
    (``ceil(n / factor)`` samples). Gain (computed for factors 2-13): within 0.35 % of 1 up to
    0.8 of the new Nyquist frequency fs/(2·factor), -6 dB at it, below -50 dB above 1.17 of
    it; content between the new Nyquist frequency and 1.17 times it is attenuated but still
    aliases. Keep the modes of interest below ~0.8·fs/(2·factor). The first and last ~10
    output samples carry the filter's edge transients.

    Parameters
    ----------
    signals : Signals or array_like, shape (n_samples,) or (n_samples, n_channels)
        All channels (forces, displacements, velocities) are filtered with the same filter.
    factor : int
        Decimation factor q >= 1 (1 returns a copy).

    Returns
    -------
    Signals or ndarray
        New Signals with ``fs / factor``, or a new array.
    """
    _check_int(factor, "factor", 1)
    if isinstance(signals, Signals):
        if signals.n_samples < 2 * (20 * factor + 1) and factor > 1:
            raise InputDataError(
                f"decimating by {factor} needs at least {2 * (20 * factor + 1)} samples, got {signals.n_samples}"
            )
        return replace(
            signals,
            force=_decimate(np.asarray(signals.force), factor),
            displacement=_decimate(np.asarray(signals.displacement), factor),
            velocity=None if signals.velocity is None else _decimate(np.asarray(signals.velocity), factor),
            fs=signals.fs / factor,
        )
    s = _as_columns(signals, "signal")
    if factor > 1 and s.array.shape[0] < 2 * (20 * factor + 1):
        raise InputDataError(
            f"decimating by {factor} needs at least {2 * (20 * factor + 1)} samples, got {s.array.shape[0]}"
        )
    return s.restore(_decimate(s.array, factor))


def _decimate(x: np.ndarray, factor: int) -> np.ndarray:
    if factor == 1:
        return np.array(x, dtype=float, copy=True)
    return np.ascontiguousarray(_signal.decimate(x, factor, ftype="fir", zero_phase=True, axis=0))


def upsample(signals, factor: int):
    """Band-limited interpolation onto a grid ``factor`` times finer (FFT zero padding).

    Each channel is extended by its mirror image (so the periodic extension has no jump at
    the record's ends), transformed, zero-padded to the finer rate and transformed back;
    output sample ``j·factor`` equals input sample ``j`` to rounding. This is exact for a
    band-limited record. NSI uses it (``identify(..., upsample=R)``) to evaluate
    discontinuous nonlinear terms such as sign(ż) on a finer grid (SPEC 2 and 10): on the
    negative-stiffness twin (512 Hz, noise-free) the sign-friction coefficient error falls
    from -2.3 % to -0.6 % with R = 2.

    Parameters
    ----------
    signals : Signals or array_like, shape (n_samples,) or (n_samples, n_channels)
    factor : int
        Interpolation factor R >= 1 (1 returns a copy).

    Returns
    -------
    Signals or ndarray
        New Signals with ``fs · factor`` and ``n_samples · factor`` samples (the last
        ``factor - 1`` lie after the last input sample), or a new array.
    """
    _check_int(factor, "factor", 1)
    if isinstance(signals, Signals):
        return replace(
            signals,
            force=_upsample(np.asarray(signals.force), factor),
            displacement=_upsample(np.asarray(signals.displacement), factor),
            velocity=None if signals.velocity is None else _upsample(np.asarray(signals.velocity), factor),
            fs=signals.fs * factor,
        )
    s = _as_columns(signals, "signal")
    return s.restore(_upsample(s.array, factor))


def _upsample(x: np.ndarray, factor: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if factor == 1:
        return x.copy()
    n = x.shape[0]
    mirrored = np.concatenate([x, x[::-1]], axis=0)  # even extension: periodic, no jump
    spectrum = np.fft.rfft(mirrored, axis=0)
    fine = np.zeros((n * factor + 1,) + x.shape[1:], dtype=complex)  # rfft size of 2·n·factor
    fine[: spectrum.shape[0]] = spectrum
    fine[spectrum.shape[0] - 1] *= 0.5  # split the old Nyquist bin between ±f_N
    return np.ascontiguousarray(np.fft.irfft(fine, n=2 * n * factor, axis=0)[: n * factor] * factor)


def select_segment(signals, start, stop, unit: str = "sample", fs: float | None = None):
    """A contiguous stretch of a record, as a copy.

    Parameters
    ----------
    signals : Signals or array_like, shape (n_samples, ...)
    start, stop : int or float
        Half-open window ``[start, stop)``: sample indices (``unit="sample"``), or times in
        seconds from the first sample (``unit="s"``; sample k is at k/fs, and the window holds
        the samples with ``start <= k/fs < stop``).
    unit : {"sample", "s"}
    fs : float, optional
        Sampling frequency for ``unit="s"`` with an array (Signals carry their own).

    Returns
    -------
    Signals or ndarray
        New object; the input is not modified.

    Raises
    ------
    InputDataError
        For an empty window or one outside the record.
    """
    is_signals = isinstance(signals, Signals)
    n = signals.n_samples if is_signals else np.asarray(signals).shape[0]
    if unit == "s":
        rate = signals.fs if is_signals else fs
        if rate is None:
            raise InputDataError("select_segment with unit='s' on an array needs fs")
        rate = _check_fs(rate)
        start = int(math.ceil(start * rate - 1e-9))
        stop = int(math.ceil(stop * rate - 1e-9))
    elif unit == "sample":
        if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in (start, stop)):
            raise InputDataError(f"sample indices must be integers, got start={start!r}, stop={stop!r}")
    else:
        raise InputDataError(f"unit must be 'sample' or 's', got {unit!r}")
    if not 0 <= start < stop <= n:
        raise InputDataError(f"segment [{start}, {stop}) is empty or outside the record of {n} samples")
    if is_signals:
        return signals.segment(int(start), int(stop))
    return np.array(np.asarray(signals)[start:stop], dtype=float, copy=True)


# ---------------------------------------------------------------------------------------------
# helpers


class _Columns:
    """An input array as float (n, c) plus how to give results back the same shape."""

    def __init__(self, values, name: str):
        arr = np.array(values, dtype=float, copy=True)
        if arr.ndim not in (1, 2):
            raise InputDataError(f"{name} must have shape (n_samples,) or (n_samples, n_channels), got {arr.shape}")
        self.squeeze = arr.ndim == 1
        self.array = arr.reshape(arr.shape[0], -1)
        if self.array.shape[0] < 8:
            raise InputDataError(f"{name} needs at least 8 samples, got {self.array.shape[0]}")
        bad = ~np.isfinite(self.array)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise InputDataError(
                f"{name} holds {int(bad.sum())} NaN/Inf value(s), the first at sample {row}, channel {col}; "
                "fill or cut them out first"
            )

    def restore(self, out: np.ndarray) -> np.ndarray:
        out = np.ascontiguousarray(out)
        return out[:, 0].copy() if self.squeeze else out


def _as_columns(values, name: str) -> _Columns:
    return _Columns(values, name)


def _poly_detrend(x: np.ndarray, order: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if order == 0 or n < 2:
        return x - x.mean(axis=0)
    tau = np.linspace(-1.0, 1.0, n)
    basis = np.polynomial.legendre.legvander(tau, order)
    coef, *_ = np.linalg.lstsq(basis, x.reshape(n, -1), rcond=None)
    return x - (basis @ coef).reshape(x.shape)


def _check_fs(fs) -> float:
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.floating, np.integer)) or not (
        math.isfinite(fs) and fs > 0
    ):
        raise InputDataError(f"fs must be a positive number of Hz, got {fs!r}")
    return float(fs)


def _check_band(band, fs: float, allow_dc: bool) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in band)
    except (TypeError, ValueError):
        raise InputDataError(f"band_hz must be a pair (f_lo, f_hi) in Hz, got {band!r}") from None
    low_ok = lo >= 0 if allow_dc else lo > 0
    if not (math.isfinite(lo) and math.isfinite(hi) and low_ok and lo < hi):
        need = "0 <= f_lo < f_hi" if allow_dc else "0 < f_lo < f_hi (f_lo > 0: integration needs a high-pass)"
        raise InputDataError(f"band_hz must satisfy {need}, got {band!r}")
    if lo >= fs / 2:
        raise InputDataError(f"band_hz f_lo = {lo} Hz must be below the Nyquist frequency {fs / 2} Hz")
    return lo, hi


def _check_taper(taper) -> None:
    if isinstance(taper, bool) or not isinstance(taper, (int, float)) or not 0 <= taper < 1:
        raise InputDataError(f"taper must be a number in [0, 1), got {taper!r}")


def _check_int(value, name: str, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputDataError(f"{name} must be an integer >= {minimum}, got {value!r}")
