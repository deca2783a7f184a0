"""Measurement-noise level of the recorded channels, estimated from the data (docs/method.md §10).

Used by the output-error pole refinement (:mod:`._output_error`) and by the errors-in-variables
predictor (:mod:`._eiv`), which both weigh or model the noise of each output channel.
"""

from __future__ import annotations

import numpy as np

from ..signals import Signals
from .steady import period_scatter_std

__all__ = ["column_std", "measured_noise_std", "row_var", "white_noise_std"]

_MAX_DIFFERENCE_ORDER = 6


def white_noise_std(signal: np.ndarray) -> np.ndarray:
    """Std of additive white noise per channel, from high-order differences.

    For white noise ``var(Δᵈ e) = C(2d, d) σ²``, while a signal well below Nyquist is
    attenuated by ``(2 sin(πf/fs))^{2d}``. The estimate is the smallest of
    ``var(Δᵈ y) / C(2d, d)`` over d = 2..6 (leakage of the signal only inflates it).

    Parameters
    ----------
    signal : ndarray, shape (n_samples, n_channels)

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    # one contiguous row per channel: reductions along rows are ~7x faster than down the
    # columns of an (n_samples, few channels) array, and this runs in every identification
    y = np.ascontiguousarray(np.asarray(signal, dtype=float).T)
    best = np.full(y.shape[0], np.inf)
    diff = y
    for d in range(1, _MAX_DIFFERENCE_ORDER + 1):
        diff = diff[:, 1:] - diff[:, :-1]
        if d >= 2:
            norm = float(
                np.prod(np.arange(d + 1, 2 * d + 1)) / np.prod(np.arange(1, d + 1))
            )  # C(2d, d)
            best = np.minimum(best, row_var(diff) / norm)
    return np.sqrt(best)


def row_var(rows: np.ndarray) -> np.ndarray:
    """Variance of each row of a C-contiguous 2-D array (two passes, as :meth:`numpy.ndarray.var`).

    Parameters
    ----------
    rows : ndarray, shape (n_channels, n_samples)

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    centred = rows - rows.mean(axis=1, keepdims=True)
    return np.einsum("ij,ij->i", centred, centred) / rows.shape[1]


def column_std(columns: np.ndarray) -> np.ndarray:
    """Standard deviation of each column of an (n_samples, n_channels) array (fast path of ``std(axis=0)``).

    Parameters
    ----------
    columns : ndarray, shape (n_samples, n_channels)

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    return np.sqrt(row_var(np.ascontiguousarray(np.asarray(columns, dtype=float).T)))


def measured_noise_std(signals: Signals):
    """Noise std of the measured displacement and velocity channels (docs/method.md §10).

    With measured velocities the two channels of a DOF must agree: ``r = v - dx/dt`` (spectral
    derivative, exact for band-limited records) holds only the noise, whose one-sided spectral
    density is ``(2/fs)(σ_v² + ω² σ_x²)`` for white noise. A fit of that line to the Welch
    spectrum of ``r`` (relative least squares) gives both stds; records shorter than 256 samples,
    or fits that fail, fall back to :func:`white_noise_std`. High-order differences alone
    (:func:`white_noise_std`) cannot tell a velocity's noise from its broadband content, and
    overestimate it at a driven DOF. On two or more whole periods (``signals.period``) both are the
    scatter between periods (:func:`bayesnsi.nsi.steady.period_scatter_std`): accelerations integrated
    line by line carry their noise inside the integration band only, where differences and the
    (exactly consistent) v - dx/dt see none (trial of a GVT file: 5e-18 m against 1.6e-4 m).

    Parameters
    ----------
    signals : Signals

    Returns
    -------
    displacement_std : ndarray, shape (l,)
    velocity_std : ndarray, shape (l,) or None
        None when the signals carry no velocities.
    """
    x = np.asarray(signals.displacement, dtype=float)
    realisations = getattr(signals, "realisations", 1)
    scatter = period_scatter_std(x, getattr(signals, "period", None), realisations)
    if scatter is not None:  # whole periods: the noise is what changes between them (integrated too)
        v = signals.velocity
        return scatter, None if v is None else period_scatter_std(np.asarray(v, dtype=float), signals.period,
                                                                  realisations)
    disp = white_noise_std(x)
    if signals.velocity is None:
        return disp, None
    v = np.asarray(signals.velocity, dtype=float)
    vel = white_noise_std(v)
    n = len(x)
    if n < 256:
        return disp, vel
    from scipy import signal as _signal

    omega = 2.0 * np.pi * np.fft.rfftfreq(n, 1.0 / signals.fs)
    derivative = np.fft.irfft(1j * omega[:, None] * np.fft.rfft(x - x.mean(axis=0), axis=0), n=n, axis=0)
    edge = n // 20  # the spectral derivative wraps around: drop the ends
    mismatch = (v - v.mean(axis=0) - derivative)[edge : n - edge]
    freqs, density = _signal.welch(mismatch, fs=signals.fs, nperseg=min(1024, len(mismatch) // 8), axis=0)
    variance = density[1:-1] * signals.fs / 2.0  # per-sample variance density: σ_v² + ω² σ_x²
    design = np.column_stack([np.ones(len(variance)), (2.0 * np.pi * freqs[1:-1]) ** 2])
    for c in range(x.shape[1]):
        coef = _relative_line_fit(design, variance[:, c])
        if coef is not None and coef[1] > 0:
            disp[c] = np.sqrt(coef[1])
            vel[c] = np.sqrt(max(coef[0], 0.0)) or 1e-6 * v[:, c].std()
    return disp, vel


def _relative_line_fit(design: np.ndarray, target: np.ndarray, passes: int = 30):
    """Coefficients minimising Σ ((design @ c - target) / fit)², or None when the fit fails.

    It fails on a spectrum with (numerically) empty bins, e.g. a record interpolated onto a finer
    grid (``identify(upsample=R)``), whose noise is band-limited to the data's Nyquist frequency.
    """
    with np.errstate(all="ignore"):
        scaled = design / target[:, None]
        if not np.all(np.isfinite(scaled)) or not np.all(target > 0):
            return None
        try:
            coef = np.linalg.lstsq(scaled, np.ones(len(target)), rcond=None)[0]
            for _ in range(passes):  # relative least squares: weights from the current fit
                fitted = np.maximum(design @ coef, np.finfo(float).tiny)
                lhs, rhs = design / fitted[:, None], target / fitted
                if not (np.all(np.isfinite(lhs)) and np.all(np.isfinite(rhs))):
                    return None
                coef = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
        except np.linalg.LinAlgError:
            return None
    return coef if np.all(np.isfinite(coef)) else None
