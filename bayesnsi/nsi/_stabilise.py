"""Unstable poles of the time route outside the band the data inform (issue 17, item 4).

A subspace model of integrated accelerations can hold a growing pole below the excited band
(where the integrated data hold only drift) or above it: one such pole made the whole candidate
fail. Poles outside ``[nsi] band_hz`` are mirrored into the unit circle (``z -> 1/conj(z)``: the
same frequency, the mirrored decay) before B and D are fitted, with a warning that names them; an
unstable pole inside the band is still a failure of the candidate (the data say something is wrong).
"""

from __future__ import annotations

import numpy as np

__all__ = ["pole_text", "reflect_out_of_band"]


def _frequency_hz(z: np.ndarray, dt: float) -> np.ndarray:
    return np.abs(np.angle(z)) / (2 * np.pi * dt)


def reflect_out_of_band(A: np.ndarray, dt: float, band_hz) -> tuple[np.ndarray, np.ndarray] | None:
    """``A`` with its unstable eigenvalues outside ``band_hz`` mirrored into the unit circle.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Discrete state matrix.
    dt : float
        Its sampling interval [s].
    band_hz : (float, float) or None
        The band the data inform; None: no pole is known to be outside it.

    Returns
    -------
    (ndarray, ndarray) or None
        The stabilised real A and the mirrored poles (one of each conjugate pair, as identified);
        None when an unstable pole lies inside the band or no band is given.
    """
    lam, vec = np.linalg.eig(A)
    unstable = np.abs(lam) >= 1.0
    if band_hz is None or not unstable.any():
        return None if unstable.any() else (A, lam[:0])
    freqs = _frequency_hz(lam, dt)
    inside = (freqs >= band_hz[0]) & (freqs <= band_hz[1])
    if np.any(unstable & inside):
        return None
    mirrored = lam.copy()
    mirrored[unstable] = 1.0 / np.conj(lam[unstable])
    stable = np.real(vec @ np.diag(mirrored) @ np.linalg.inv(vec))
    if np.max(np.abs(np.linalg.eigvals(stable))) >= 1.0:  # defective A: the mirror did not hold
        return None
    shown = lam[unstable & (lam.imag >= 0)]
    return stable, shown


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
