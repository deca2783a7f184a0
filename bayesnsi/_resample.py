"""Detrending, resampling and cutting of records (re-exported by :mod:`bayesnsi.preprocess`).

numpy/scipy only. Every function accepts a :class:`~bayesnsi.signals.Signals` or an array of
shape ``(n_samples,)`` or ``(n_samples, n_channels)`` and returns a new object of the same kind;
the input is never modified.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ._sampled import as_columns, check_fs, check_int, poly_detrend
from .exceptions import InputDataError
from .signals import Signals

__all__ = ["detrend", "decimate", "upsample", "select_segment"]


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
    check_int(order, "order", 0)
    if isinstance(signals, Signals):
        return replace(
            signals,
            force=poly_detrend(np.asarray(signals.force), order),
            displacement=poly_detrend(np.asarray(signals.displacement), order),
            velocity=None if signals.velocity is None else poly_detrend(np.asarray(signals.velocity), order),
        )
    s = as_columns(signals, "signal")
    return s.restore(poly_detrend(s.array, order))


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
    check_int(factor, "factor", 1)
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
    s = as_columns(signals, "signal")
    if factor > 1 and s.array.shape[0] < 2 * (20 * factor + 1):
        raise InputDataError(
            f"decimating by {factor} needs at least {2 * (20 * factor + 1)} samples, got {s.array.shape[0]}"
        )
    return s.restore(_decimate(s.array, factor))


def _decimate(x: np.ndarray, factor: int) -> np.ndarray:
    from scipy import signal as _signal  # when needed: 0.4 s to import
    if factor == 1:
        return np.array(x, dtype=float, copy=True)
    return np.ascontiguousarray(_signal.decimate(x, factor, ftype="fir", zero_phase=True, axis=0))


def upsample(signals, factor: int):
    """Band-limited interpolation onto a grid ``factor`` times finer (FFT zero padding).

    Each channel is extended by its mirror image (so the periodic extension has no jump at
    the record's ends), transformed, zero-padded to the finer rate and transformed back;
    output sample ``j·factor`` equals input sample ``j`` to rounding. This is exact for a
    band-limited record. NSI uses it (``identify(..., upsample=R)``) to evaluate
    discontinuous nonlinear terms such as sign(ż) on a finer grid (docs/method.md §2 and 10): on the
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
    check_int(factor, "factor", 1)
    if isinstance(signals, Signals):
        return replace(
            signals,
            force=_upsample(np.asarray(signals.force), factor),
            displacement=_upsample(np.asarray(signals.displacement), factor),
            velocity=None if signals.velocity is None else _upsample(np.asarray(signals.velocity), factor),
            fs=signals.fs * factor,
        )
    s = as_columns(signals, "signal")
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
        rate = check_fs(rate)
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
