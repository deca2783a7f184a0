"""White-noise level of measured accelerations, before they are integrated (docs/method.md §11).

Integration leaves an accelerometer's noise only in the integration band, weighted by 1/ω² and
1/ω⁴, where no estimate on the integrated signal can tell it from the motion. On the acceleration
itself the noise is white and the signal is not, so two estimates that the signal can only inflate
are taken per channel and the smaller kept:

* high-order differences (:func:`bayesnsi.noise.white_noise_std`): the signal's content far below
  Nyquist is removed; content near Nyquist (a force broadband up to fs/2 drives the mass line of
  every acceleration there) is read as noise;
* with the forces, the part of the acceleration's spectrum they do not explain, the residual of
  the multiple-input H1 fit per line, ``S_aa - S_af S_ff⁻¹ S_fa`` (Hann-windowed Welch segments,
  50 % overlap), its median over the lines between ``f_lo`` and 0.95 of Nyquist: a white noise
  gives the same level on every line, the nonlinear distortion and leakage of the resonances
  raise only some; where the force leaves at least 8 lines unexcited (below 1e-4 of its strongest
  line) the median over those is taken when lower (cubic chain under a 1-30 Hz force at 100 Hz:
  all lines 1.04-1.06x the simulated noise, unexcited lines 0.96-1.03x). Its expectation is
  ``σ² Σw² (K - m)`` for K segments and m forces, and the
  median of the scaled χ² with ν = 2(K - m) degrees of freedom is ``ν (1 - 2/(9ν))³`` (Wilson-
  Hilferty); both are divided out.
"""

from __future__ import annotations

import numpy as np

from .levels import white_noise_std

__all__ = ["acceleration_noise_std"]

_SEGMENT = 1024  # Welch segment length (halved until the record holds at least 16 segments)
_TOP = 0.95  # lines up to this fraction of Nyquist (the decimation / anti-alias roll-off above)
_QUIET = 1e-4  # a line the force leaves unexcited holds less than this share of its strongest line's power


def acceleration_noise_std(acceleration, fs: float, force=None, f_lo: float = 0.0) -> np.ndarray:
    """White noise std of each acceleration channel (module notes).

    Parameters
    ----------
    acceleration : array_like, shape (n_samples, l)
        Measured accelerations, before integration.
    fs : float
        Sampling frequency [Hz].
    force : array_like, shape (n_samples, m), optional
        Measured forces (before any band filter); without them, differences only.
    f_lo : float
        Lowest frequency of the lines the spectral estimate reads [Hz] (the integration band's
        lower edge: below it drift and 1/f noise need not be white).

    Returns
    -------
    ndarray, shape (l,)
        The smaller of the two estimates per channel.
    """
    a = np.asarray(acceleration, dtype=float)
    a = a.reshape(len(a), -1)
    by_differences = white_noise_std(a)
    if force is None:
        return by_differences
    f = np.asarray(force, dtype=float)
    f = f.reshape(len(f), -1)
    floor = _unexplained_floor(a, f, float(fs), float(f_lo))
    return by_differences if floor is None else np.minimum(by_differences, floor)


def _unexplained_floor(a: np.ndarray, f: np.ndarray, fs: float, f_lo: float) -> np.ndarray | None:
    """Median over lines of the acceleration power the forces do not explain, as a white-noise std."""
    n, m = f.shape
    length = _SEGMENT
    while length > 64 and n // (length // 2) - 1 < 16:
        length //= 2
    step = length // 2
    k_seg = (n - length) // step + 1
    if k_seg < max(16, 4 * m):
        return None
    window = np.hanning(length)
    starts = step * np.arange(k_seg)
    index = starts[:, None] + np.arange(length)[None, :]

    def segments(x):  # (K, lines, channels)
        chunks = x[index] - x[index].mean(axis=1, keepdims=True)
        return np.fft.rfft(window[None, :, None] * chunks, axis=1)

    F, A = segments(f), segments(a)
    freqs = np.fft.rfftfreq(length, 1.0 / fs)
    lines = (freqs > max(f_lo, 2.5 * fs / length)) & (freqs < _TOP * fs / 2)
    if lines.sum() < 8:
        return None
    F, A = F[:, lines], A[:, lines]
    sff = np.einsum("kli,klj->lij", F, F.conj())  # Σ_k F F^H per line
    sfa = np.einsum("kli,klo->lio", F.conj(), A)
    saa = np.einsum("klo,klo->lo", A, A.conj()).real
    ridge = 1e-12 * np.trace(sff, axis1=1, axis2=2).real[:, None, None] * np.eye(m)
    try:
        h = np.linalg.solve(sff + ridge, sfa)
    except np.linalg.LinAlgError:
        return None
    explained = np.einsum("lio,lio->lo", sfa.conj(), h).real
    residual = np.maximum(saa - explained, 0.0)
    dof = 2 * (k_seg - m)
    median_factor = (1.0 - 2.0 / (9.0 * dof)) ** 3  # median of χ²_ν / ν
    per_line = residual / ((k_seg - m) * np.sum(window**2))
    level = np.median(per_line, axis=0)
    power = np.trace(sff, axis1=1, axis2=2).real
    quiet = power < _QUIET * power.max()  # lines the force leaves unexcited: noise (and distortion) only
    if quiet.sum() >= 8:
        level = np.minimum(level, np.median(per_line[quiet], axis=0))
    return np.sqrt(level / median_factor)
