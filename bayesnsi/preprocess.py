"""Sensor conversions before identification: integration, band filtering, detrending, decimation.

numpy/scipy only. Every function returns new arrays (or new :class:`~bayesnsi.signals.Signals`)
and never modifies its input. Array convention of bayesnsi: ``(n_samples, n_channels)``; a 1-D
array is treated as one channel and returned 1-D.

- :func:`integrate_acceleration`: accelerometer -> (velocity, displacement), by frequency-domain
  division by jω / (jω)² with a zero-phase band window, or by the trapezoid rule with polynomial
  detrending and a zero-phase Butterworth high-pass.
- :func:`integrate_velocity`: velocity sensor (a laser vibrometer, a geophone) -> (velocity in the
  band, displacement), the same recipe with one integration.
- :func:`band_filter`: the *same* zero-phase band weighting applied to other channels (the
  forces), so that input and output see one filter and the in-band input-output relation is kept.
- :func:`detrend`, :func:`decimate`, :func:`select_segment`: on arrays or on Signals.

The integration paths are used by :func:`bayesnsi.io.load_signals` when the config has
``[data] integrate`` with ``accelerations`` or with ``velocities`` alone (see
:class:`bayesnsi.io.DataSpec`).
"""

from __future__ import annotations

import math

import numpy as np

from ._resample import decimate, detrend, select_segment, upsample
from ._sampled import as_columns, check_band, check_fs, check_int, check_taper, poly_detrend
from .exceptions import InputDataError

__all__ = [
    "INTEGRATION_METHODS",
    "INTEGRATED_QUANTITIES",
    "integrate_acceleration",
    "integrate_measured",
    "integrate_velocity",
    "band_filter",
    "band_window",
    "detrend",
    "decimate",
    "upsample",
    "select_segment",
]

INTEGRATION_METHODS = ("frequency", "time")
"""Methods of :func:`integrate_acceleration` and :func:`integrate_velocity`."""

INTEGRATED_QUANTITIES = ("acceleration", "velocity")
"""What a sensor integrated on load measured: integrated twice or once to a displacement."""


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
    lo, hi = check_band(band_hz, fs, allow_dc=True)
    check_taper(taper)
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
    return _integrate(acc, "acceleration", 2, fs, band_hz, method, taper, pad_s, filter_order, detrend_order)


def integrate_velocity(
    vel,
    fs: float,
    band_hz: tuple[float, float],
    method: str = "frequency",
    *,
    taper: float = 0.5,
    pad_s: float | None = None,
    filter_order: int = 4,
    detrend_order: int = 2,
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity in the band and displacement from a measured velocity (laser vibrometer, geophone).

    The recipe of :func:`integrate_acceleration` with one integration: "frequency" multiplies the
    spectrum by ``W(f)`` and ``W(f)/(jω)``; "time" integrates once by the trapezoid rule with the
    polynomial detrend and the zero-phase Butterworth high-pass (twice) applied to both outputs.
    The velocity is returned filtered by the same band, so that it stays the derivative of the
    displacement; the velocity noise reaches the displacement as ``|W(f)|²/(2πf)²``, mostly near
    ``f_lo``.

    Parameters
    ----------
    vel : array_like, shape (n_samples,) or (n_samples, n_channels)
        Velocities [m/s] (any unit u; the displacement is in u·s).
    fs, band_hz, method, taper, pad_s, filter_order, detrend_order
        As in :func:`integrate_acceleration`.

    Returns
    -------
    velocity, displacement : ndarray
        Same shape as ``vel``; new arrays.

    Raises
    ------
    InputDataError
        For a bad band, method or shape, NaN/Inf values, or fewer than 8 samples.
    """
    return _integrate(vel, "velocity", 1, fs, band_hz, method, taper, pad_s, filter_order, detrend_order)


def integrate_measured(signal, measured: str, fs: float, band_hz: tuple[float, float], method: str = "frequency",
                       **options) -> tuple[np.ndarray, np.ndarray]:
    """:func:`integrate_acceleration` or :func:`integrate_velocity`, as ``measured`` names the sensors.

    Parameters
    ----------
    signal : array_like, shape (n_samples,) or (n_samples, n_channels)
    measured : {"acceleration", "velocity"}
        What the sensors measured (:data:`INTEGRATED_QUANTITIES`).
    fs, band_hz, method, **options
        As in :func:`integrate_acceleration`.

    Returns
    -------
    velocity, displacement : ndarray
    """
    if measured not in INTEGRATED_QUANTITIES:
        raise InputDataError(f"measured must be one of {INTEGRATED_QUANTITIES}, got {measured!r}")
    integrate = integrate_acceleration if measured == "acceleration" else integrate_velocity
    return integrate(signal, fs, band_hz, method, **options)


def _integrate(signal, name: str, times: int, fs, band_hz, method, taper, pad_s, filter_order, detrend_order):
    """(velocity, displacement) of ``signal`` integrated ``times`` (1 or 2) times by ``method``."""
    s = as_columns(signal, name)
    fs = check_fs(fs)
    lo, hi = check_band(band_hz, fs, allow_dc=False)
    if method not in INTEGRATION_METHODS:
        raise InputDataError(f"unknown integration method {method!r}; use one of {INTEGRATION_METHODS}")
    if method == "frequency":
        check_taper(taper)
        velocity, displacement = _frequency_filter(s.array, fs, (lo, hi), taper, pad_s, powers=(times - 1, times))
    else:
        velocity, displacement = _time_integrate(s.array, fs, (lo, hi), filter_order, detrend_order, times)
    return s.restore(velocity), s.restore(displacement)


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
    s = as_columns(signal, "signal")
    fs = check_fs(fs)
    lo, hi = check_band(band_hz, fs, allow_dc=True)
    if method not in INTEGRATION_METHODS:
        raise InputDataError(f"unknown filter method {method!r}; use one of {INTEGRATION_METHODS}")
    if method == "frequency":
        check_taper(taper)
        (out,) = _frequency_filter(s.array, fs, (lo, hi), taper, pad_s, powers=(0,))
    else:
        out = _butter_band(s.array, fs, (lo, hi), filter_order)
    return s.restore(out)


def _frequency_filter(a, fs, band, taper, pad_s, powers):
    from scipy import fft as _fft  # when needed: 0.1 s to import

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


def _time_integrate(a, fs, band, order, detrend_order, times: int = 2):
    from scipy import signal as _signal  # when needed: 0.4 s to import
    from scipy.integrate import cumulative_trapezoid  # 0.1 s to import

    dt = 1.0 / fs
    check_int(order, "filter_order", 1)
    check_int(detrend_order, "detrend_order", 0)
    high = _signal.butter(order, band[0], btype="highpass", fs=fs, output="sos")
    # a velocity is detrended as measured; an acceleration is integrated to one first
    v0 = poly_detrend(a if times == 1 else cumulative_trapezoid(a, dx=dt, axis=0, initial=0.0), detrend_order)
    v1 = _filtfilt(high, v0)
    x = _filtfilt(high, poly_detrend(cumulative_trapezoid(v1, dx=dt, axis=0, initial=0.0), detrend_order))
    v = _filtfilt(high, v1)
    if band[1] < fs / 2:
        low = _signal.butter(order, band[1], btype="lowpass", fs=fs, output="sos")
        v, x = _filtfilt(low, v), _filtfilt(low, x)
    return v, x


def _butter_band(s, fs, band, order):
    from scipy import signal as _signal  # when needed: 0.4 s to import
    check_int(order, "filter_order", 1)
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
    from scipy import signal as _signal  # when needed: 0.4 s to import
    return _signal.sosfiltfilt(sos, x, axis=0)
