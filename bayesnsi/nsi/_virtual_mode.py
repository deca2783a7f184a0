"""The mode a virtual spring adds to a body without damping to ground (free-free structures).

With the known stabilising spring of :mod:`bayesnsi.nsi.free_body` the rigid-body mode becomes an
oscillation at about ``√(k/M)``. Its damping is only what dissipates *to ground*: a carriage on a
guide with viscous friction (the EMPS axis) damps it, but a free-free structure whose damping is
all between its masses (two carriages joined by a spring and a damper, an air-bearing test
article) leaves it undamped, friction being on the input side as a nonlinear term. The subspace
estimate then scatters around the unit circle (on a free-free two-mass record, 30 000 samples:
``|z| = 1.000022`` at 0.93 Hz, ζ = -0.002) and the stabilised model was refused as unstable
although the free body is what the data hold. Such a lightly unstable pole is mirrored into the
circle (``z -> 1/conj(z)``: same frequency, damping sign flipped), which changes its response over
the record by less than its own estimation error; the virtual spring is removed afterwards
(:func:`bayesnsi.nsi.free_body.free_model`), so the physical poles are unaffected.
"""

from __future__ import annotations

import numpy as np

from ._stabilise import mirror_eigenvalues

__all__ = ["VIRTUAL_MODE_MAX_NEGATIVE_DAMPING", "mirror_undamped", "physical_mirrored"]

VIRTUAL_MODE_MAX_NEGATIVE_DAMPING = 0.2
"""Largest negative damping ratio of an unstable oscillatory pole mirrored as the virtual mode."""

_SAME_MODE = 0.05
"""Relative frequency difference within which a mirrored pole is a mode of the free model."""


def mirror_undamped(A: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray] | None:
    """``A`` with its unstable oscillatory eigenvalues (``ζ >= -0.2``) mirrored into the unit circle.

    Only for a model identified with a virtual spring (:mod:`bayesnsi.nsi.free_body`): an undamped
    virtual mode is expected there; :func:`physical_mirrored` checks afterwards that only that
    mode was mirrored.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Discrete state matrix.
    dt : float
        Its sampling interval [s].

    Returns
    -------
    (ndarray, ndarray) or None
        The real A with every eigenvalue inside the unit circle and the mirrored poles (one of each
        conjugate pair, as identified); None when an unstable eigenvalue is real, is damped more
        negatively than :data:`VIRTUAL_MODE_MAX_NEGATIVE_DAMPING`, or A is defective.
    """
    lam, vec = np.linalg.eig(A)
    unstable = np.abs(lam) >= 1.0
    if not unstable.any():
        return A, lam[:0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(lam.astype(complex)) / dt
        zeta = -s.real / np.abs(s)
    oscillatory = (np.abs(lam.imag) > 0) & (zeta >= -VIRTUAL_MODE_MAX_NEGATIVE_DAMPING)
    if np.any(unstable & ~oscillatory):
        return None
    stable = mirror_eigenvalues(lam, vec, unstable)
    return None if stable is None else (stable, lam[unstable & (lam.imag >= 0)])


def physical_mirrored(mirrored: np.ndarray, modes, dt: float) -> list[float]:
    """Frequencies [Hz] of mirrored poles that are still modes of the free model (not the virtual mode).

    Parameters
    ----------
    mirrored : ndarray of complex
        Discrete poles :func:`mirror_undamped` mirrored.
    modes : sequence of Mode
        Physical modes of the free model (virtual spring removed).
    dt : float
        Sampling interval [s].

    Returns
    -------
    list of float
        Empty when every mirrored pole was the virtual spring's mode.
    """
    freqs = np.abs(np.angle(np.asarray(mirrored, dtype=complex))) / (2 * np.pi * dt)
    physical = [m.frequency_hz for m in modes]
    return [float(f) for f in freqs if any(abs(p - f) <= _SAME_MODE * f for p in physical)]
