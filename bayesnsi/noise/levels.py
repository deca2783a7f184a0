"""Noise levels of recorded channels, estimated from the data alone (docs/method.md §10).

* :func:`white_noise_std`: white noise from high-order differences (a signal well below Nyquist
  is removed by them);
* :func:`measured_noise_std`: displacement and velocity noise of a record jointly, from the
  mismatch between measured velocities and the derivative of measured displacements (or the
  period scatter); the output-error pole refinement and the errors-in-variables predictor of
  :mod:`bayesnsi.nsi` weigh and model each output channel's noise with it.
"""

from __future__ import annotations

import numpy as np

from ..signals import Signals
from .periodic import period_scatter_std

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
    scatter between periods (:func:`bayesnsi.noise.periodic.period_scatter_std`): accelerations integrated
    line by line carry their noise inside the integration band only, where differences and the
    (exactly consistent) v - dx/dt see none (a measured ground vibration test: 5e-18 m against 1.6e-4 m).

    Parameters
    ----------
    signals : Signals

    Returns
    -------
    displacement_std : ndarray, shape (l,)
    velocity_std : ndarray, shape (l,) or None
        None when the signals carry no velocities. Both read-only, computed once per
        :class:`~bayesnsi.signals.Signals` (whose arrays are read-only copies).
    """
    if not isinstance(signals, Signals):
        return _estimate_noise_std(signals)
    memo = vars(signals)  # Signals hold read-only copies of the data: once per record (every candidate reads it)
    if _MEMO_KEY not in memo:
        memo[_MEMO_KEY] = tuple(None if v is None else _read_only(v) for v in _estimate_noise_std(signals))
    return memo[_MEMO_KEY]


_MEMO_KEY = "_measured_noise_std"


def _read_only(values: np.ndarray) -> np.ndarray:
    """A read-only copy of ``values`` (float)."""
    values = np.array(values, dtype=float)
    values.setflags(write=False)
    return values


def _estimate_noise_std(signals: Signals):
    """:func:`measured_noise_std` without the memo."""
    x = np.asarray(signals.displacement, dtype=float)
    scatter = period_scatter_std(x, signals.period, signals.realisations)
    if scatter is not None:  # whole periods: the noise is what changes between them (integrated too)
        v = signals.velocity
        return scatter, None if v is None else period_scatter_std(np.asarray(v, dtype=float), signals.period,
                                                                  signals.realisations)
    if signals.velocity is None:
        return white_noise_std(x), None
    v = np.asarray(signals.velocity, dtype=float)
    n = len(x)
    if n < 256:
        return white_noise_std(x), white_noise_std(v)
    from scipy import signal as _signal

    omega = 2.0 * np.pi * np.fft.rfftfreq(n, 1.0 / signals.fs)
    derivative = np.fft.irfft(1j * omega[:, None] * np.fft.rfft(x - x.mean(axis=0), axis=0), n=n, axis=0)
    edge = n // 20  # the spectral derivative wraps around: drop the ends
    mismatch = (v - v.mean(axis=0) - derivative)[edge : n - edge]
    freqs, density = _signal.welch(mismatch, fs=signals.fs, nperseg=min(1024, len(mismatch) // 8), axis=0)
    variance = density[1:-1] * signals.fs / 2.0  # per-sample variance density: σ_v² + ω² σ_x²
    design = np.column_stack([np.ones(len(variance)), (2.0 * np.pi * freqs[1:-1]) ** 2])
    fits = _relative_line_fits(design, variance)
    failed = ~(np.all(np.isfinite(fits), axis=1) & (fits[:, 1] > 0))
    disp, vel = np.empty(x.shape[1]), np.empty(x.shape[1])
    if np.any(failed):  # the difference estimates, only where the fit failed (they cost as much as the fit)
        disp[failed], vel[failed] = white_noise_std(x[:, failed]), white_noise_std(v[:, failed])
    for c in np.flatnonzero(~failed):
        disp[c] = np.sqrt(fits[c, 1])
        vel[c] = np.sqrt(max(fits[c, 0], 0.0)) or 1e-6 * v[:, c].std()
    return disp, vel


def _relative_line_fits(design: np.ndarray, targets: np.ndarray, passes: int = 30) -> np.ndarray:
    """Per column of ``targets``, the two coefficients minimising Σ ((design @ c - target) / fit)².

    Iteratively reweighted least squares (weights from the current fit), all channels at once by
    their 2 x 2 normal equations on unit-scaled design columns. A channel whose fit fails gets
    NaN: a spectrum with (numerically) empty bins, e.g. a record interpolated onto a finer grid
    (``identify(upsample=R)``), whose noise is band-limited to the data's Nyquist frequency.

    Parameters
    ----------
    design : ndarray, shape (n_bins, 2)
    targets : ndarray, shape (n_bins, n_channels)

    Returns
    -------
    ndarray, shape (n_channels, 2)
    """
    scale = np.max(np.abs(design), axis=0)
    unit = design / np.where(scale > 0, scale, 1.0)
    with np.errstate(all="ignore"):
        usable = np.all(targets > 0, axis=0) & np.all(np.isfinite(targets), axis=0)
        weights = np.where(usable, 1.0 / targets, np.nan)  # first pass: relative to the data
        for _ in range(passes + 1):
            lhs = unit[:, None, :] * weights[:, :, None]  # (bins, channels, 2)
            normal = np.einsum("bci,bcj->cij", lhs, lhs)
            rhs = np.einsum("bci,bc->ci", lhs, targets * weights)
            det = normal[:, 0, 0] * normal[:, 1, 1] - normal[:, 0, 1] ** 2
            ok = np.isfinite(det) & (det > 1e-12 * normal[:, 0, 0] * normal[:, 1, 1])
            det = np.where(ok, det, np.nan)
            coef = np.stack([normal[:, 1, 1] * rhs[:, 0] - normal[:, 0, 1] * rhs[:, 1],
                             normal[:, 0, 0] * rhs[:, 1] - normal[:, 0, 1] * rhs[:, 0]], axis=1) / det[:, None]
            weights = 1.0 / np.maximum(unit @ coef.T, np.finfo(float).tiny)
        return coef / np.where(scale > 0, scale, 1.0)
