"""Unstable poles of the time route outside the band the data inform.

A subspace model of integrated accelerations can hold a growing pole below the excited band
(where the integrated data hold only drift) or above it: one such pole made the whole candidate
fail. Poles outside ``[nsi] band_hz`` *at frequencies the force does not excite* are mirrored into
the unit circle (``z -> 1/conj(z)``: the same frequency, the mirrored decay) before B and D are
fitted, with a warning that names them. An unstable pole inside the band, or outside it where the
force has power (a broadband force informs every frequency: the beam's white force up to Nyquist),
is still a failure of the candidate (the data say something is wrong).
"""

from __future__ import annotations

import numpy as np

__all__ = ["mirror_eigenvalues", "pole_text", "reflect_out_of_band", "unexcited"]


def _frequency_hz(z: np.ndarray, dt: float) -> np.ndarray:
    return np.abs(np.angle(z)) / (2 * np.pi * dt)


EXCITATION_FLOOR = 1e-2
"""A frequency is unexcited where the force's power density is below this fraction of its in-band median."""


def unexcited(force: np.ndarray, dt: float, band_hz, freqs_hz: np.ndarray) -> np.ndarray:
    """Whether the force leaves each of ``freqs_hz`` unexcited (Welch estimate, numpy only).

    Parameters
    ----------
    force : ndarray, shape (n_samples, n_inputs)
        Measured force(s).
    dt : float
        Sampling interval [s].
    band_hz : (float, float)
        The band whose median power density is the reference.
    freqs_hz : ndarray
        Frequencies to check [Hz]; one below the first line is checked on the first line above 0 Hz.

    Returns
    -------
    ndarray of bool
        True where the force's power density is below ``EXCITATION_FLOOR`` times its in-band median.
    """
    f = np.atleast_2d(np.asarray(force, dtype=float).T).T
    n = len(f)
    resolution = max(band_hz[0], 1.0 / (n * dt)) / 4  # lines fine enough to see below the band's lower edge
    length = int(min(n, 2 ** np.ceil(np.log2(max(8.0, 1.0 / (resolution * dt))))))
    starts = range(0, n - length + 1, max(1, length // 2))
    window = np.hanning(length)
    power = sum(np.sum(np.abs(np.fft.rfft(window[:, None] * (f[k:k + length] - f[k:k + length].mean(0)),
                                          axis=0)) ** 2, axis=1) for k in starts)
    lines = np.fft.rfftfreq(length, dt)
    in_band = (lines >= band_hz[0]) & (lines <= band_hz[1])
    if not in_band.any():
        return np.zeros(len(freqs_hz), dtype=bool)
    reference = np.median(power[in_band])
    index = np.clip(np.rint(np.asarray(freqs_hz) / lines[1]).astype(int), 1, len(lines) - 1)
    return power[index] < EXCITATION_FLOOR * reference


def reflect_out_of_band(A: np.ndarray, dt: float, band_hz, force: np.ndarray | None = None
                        ) -> tuple[np.ndarray, np.ndarray] | None:
    """``A`` with its unstable eigenvalues outside ``band_hz`` mirrored into the unit circle.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Discrete state matrix.
    dt : float
        Its sampling interval [s].
    band_hz : (float, float) or None
        The band the data inform; None: no pole is known to be outside it.
    force : ndarray, shape (n_samples, n_inputs), optional
        The measured force: a pole outside the band is mirrored only where the force leaves its
        frequency unexcited (:func:`unexcited`). None: every frequency outside the band counts as
        unexcited.

    Returns
    -------
    (ndarray, ndarray) or None
        The stabilised real A and the mirrored poles (one of each conjugate pair, as identified);
        None when an unstable pole lies inside the band or at a frequency the force excites, or no
        band is given.
    """
    lam, vec = np.linalg.eig(A)
    unstable = np.abs(lam) >= 1.0
    if band_hz is None or not unstable.any():
        return None if unstable.any() else (A, lam[:0])
    freqs = _frequency_hz(lam, dt)
    informed = (freqs >= band_hz[0]) & (freqs <= band_hz[1])
    if force is not None:
        informed |= ~unexcited(force, dt, band_hz, freqs)
    if np.any(unstable & informed):
        return None
    stable = mirror_eigenvalues(lam, vec, unstable)
    return None if stable is None else (stable, lam[unstable & (lam.imag >= 0)])


def mirror_eigenvalues(lam: np.ndarray, vec: np.ndarray, which: np.ndarray) -> np.ndarray | None:
    """The real matrix ``V diag(λ') V⁻¹`` with the chosen eigenvalues mirrored, ``λ' = 1/conj(λ)``.

    Parameters
    ----------
    lam, vec : ndarray
        Eigenvalues and eigenvectors of a real state matrix (:func:`numpy.linalg.eig`).
    which : ndarray of bool
        The eigenvalues to mirror (conjugate pairs together).

    Returns
    -------
    ndarray or None
        None when the result still has an eigenvalue on or outside the unit circle (a defective
        matrix: the mirror did not hold).
    """
    mirrored = lam.copy()
    mirrored[which] = 1.0 / np.conj(lam[which])
    stable = np.real(vec @ np.diag(mirrored) @ np.linalg.inv(vec))
    return None if np.max(np.abs(np.linalg.eigvals(stable))) >= 1.0 else stable


def pole_text(poles: np.ndarray, dt: float) -> str:
    """``"0.14 Hz (|z| = 1.0003), ..."`` for a warning.

    Parameters
    ----------
    poles : ndarray of complex
        Discrete poles.
    dt : float

    Returns
    -------
    str
    """
    return ", ".join(f"{f:.3g} Hz (|z| = {abs(z):.5g})" for z, f in zip(poles, _frequency_hz(poles, dt)))
