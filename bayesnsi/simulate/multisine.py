"""Periodic multisine excitation: full, odd and random-odd (docs/method.md §11; Pintelon and Schoukens, ch. 2-3).

A multisine of period ``P`` samples excites chosen DFT lines ``k`` (frequency ``k fs / P``) with
a flat amplitude and random phases. "random-odd" excites the odd lines of the band and leaves
one odd line of every group of ``group`` consecutive odd lines out at random (the even lines are
always left out): output power at the unexcited odd lines then reveals odd nonlinearities
(cubic, friction), at the even lines even ones (quadratic, asymmetric contact). Each
realisation draws new phases (and, for random-odd, new left-out lines).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import InputDataError
from .excitation import Excitation, fft_interpolate

__all__ = ["multisine", "multisine_lines"]

_KINDS = ("full", "odd", "random-odd")


def multisine_lines(period: int, fs: float, band_hz, kind: str = "full", rng=None, group: int = 4) -> np.ndarray:
    """DFT lines a multisine of one period excites.

    Parameters
    ----------
    period : int
        Samples per period P.
    fs : float
        Sampling frequency [Hz].
    band_hz : (float, float)
        Band [Hz]; lines with ``lo <= k fs / P <= hi`` (DC and Nyquist never).
    kind : {"full", "odd", "random-odd"}
        Every line of the band, its odd lines, or its odd lines less one random line of each
        group of ``group`` consecutive odd lines.
    rng : int, numpy.random.Generator or None
        Randomness of the "random-odd" choice.
    group : int
        Group size of "random-odd" (at least 2).

    Returns
    -------
    ndarray of int
        Sorted line indices k.

    Raises
    ------
    InputDataError
        On an unknown kind, a bad group or a band holding no line.
    """
    if kind not in _KINDS:
        raise InputDataError(f"multisine kind must be one of {list(_KINDS)}, got {kind!r}")
    if isinstance(group, bool) or int(group) != group or group < 2:
        raise InputDataError(f"group must be an integer >= 2, got {group!r}")
    period, fs, lo, hi = _check(period, fs, band_hz)
    k = np.arange(1, (period - 1) // 2 + 1)
    f = k * fs / period
    k = k[(f >= lo) & (f <= hi)]
    if kind != "full":
        k = k[k % 2 == 1]
    if kind == "random-odd" and len(k):
        generator = np.random.default_rng(rng)
        keep = np.ones(len(k), dtype=bool)
        for start in range(0, len(k) - group + 1, group):
            keep[start + generator.integers(group)] = False
        k = k[keep]
    if not len(k):
        raise InputDataError(
            f"band {band_hz} Hz holds no {kind} line of a {period}-sample period at {fs} Hz "
            f"(line spacing {fs / period:g} Hz); widen the band or lengthen the period"
        )
    return k


def multisine(
    period: int,
    fs: float,
    band_hz,
    rms: float,
    rng=None,
    *,
    kind: str = "full",
    n_periods: int = 1,
    oversample: int = 8,
    group: int = 4,
    lines=None,
) -> Excitation:
    """A random-phase multisine force repeated over ``n_periods`` periods.

    Parameters
    ----------
    period : int
        Samples per period P.
    fs : float
        Sampling frequency [Hz].
    band_hz : (float, float)
        Excited band [Hz].
    rms : float
        Root mean square of the samples (one channel) [N].
    rng : int, numpy.random.Generator or None
        Source of the phases (uniform on [0, 2π)) and of the random-odd lines.
    kind : {"full", "odd", "random-odd"}
        Excited lines, see :func:`multisine_lines`.
    n_periods : int
        Number of repeated periods.
    oversample : int
        Fine-grid factor for the integrator (the fine grid is exactly periodic as well).
    group : int
        Group size of "random-odd".
    lines : array_like of int, optional
        Excite exactly these lines (e.g. from :func:`multisine_lines`, to keep the same lines
        in every realisation); ``kind``, ``group`` and ``band_hz`` then only label the signal.

    Returns
    -------
    Excitation
        One channel, ``n_periods * period`` samples; ``band_hz`` recorded.

    Examples
    --------
    >>> exc = multisine(100, 10.0, (0.5, 3.0), rms=1.0, rng=0, n_periods=2)
    >>> exc.samples.shape, bool(np.allclose(exc.samples[:100], exc.samples[100:]))
    ((200, 1), True)
    """
    if isinstance(n_periods, bool) or int(n_periods) != n_periods or n_periods < 1:
        raise InputDataError(f"n_periods must be an integer >= 1, got {n_periods!r}")
    rms = float(rms)
    if not (np.isfinite(rms) and rms > 0):
        raise InputDataError(f"rms must be a positive number, got {rms!r}")
    generator = np.random.default_rng(rng)
    if lines is None:
        lines = multisine_lines(period, fs, band_hz, kind, generator, group)
    period, fs, lo, hi = _check(period, fs, band_hz)
    lines = np.asarray(lines, dtype=int)
    if not len(lines) or lines.min() < 1 or lines.max() > (period - 1) // 2:
        raise InputDataError(f"lines must be DFT lines in 1..{(period - 1) // 2}, got {lines.tolist()[:8]}")
    spectrum = np.zeros(period // 2 + 1, dtype=complex)
    spectrum[lines] = np.exp(2j * np.pi * generator.random(len(lines)))
    one = np.fft.irfft(spectrum, period)
    one *= rms / np.sqrt(np.mean(one**2))
    fine = fft_interpolate(one[:, None], int(oversample))
    samples = np.tile(one[:, None], (int(n_periods), 1))
    fine = np.tile(fine, (int(n_periods), 1))
    samples.setflags(write=False)
    fine.setflags(write=False)
    return Excitation(samples=samples, fine=fine, fs=fs, oversample=int(oversample), band_hz=(lo, hi))


def _check(period, fs, band_hz):
    if isinstance(period, bool) or int(period) != period or period < 4:
        raise InputDataError(f"period must be an integer number of samples >= 4, got {period!r}")
    fs = float(fs)
    if not (np.isfinite(fs) and fs > 0):
        raise InputDataError(f"fs must be a positive number of Hz, got {fs!r}")
    try:
        lo, hi = (float(b) for b in band_hz)
    except (TypeError, ValueError):
        raise InputDataError(f"band_hz must be a pair (low, high) in Hz, got {band_hz!r}") from None
    if not (0 <= lo < hi) or not np.isfinite(hi):
        raise InputDataError(f"band_hz must satisfy 0 <= low < high, got {band_hz!r}")
    return int(period), fs, lo, hi
