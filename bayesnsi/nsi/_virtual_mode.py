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

__all__ = ["VIRTUAL_MODE_MAX_NEGATIVE_DAMPING", "mirror_undamped"]

VIRTUAL_MODE_MAX_NEGATIVE_DAMPING = 0.01
"""Largest negative damping ratio of a pole mirrored as an undamped mode (|z| ≥ 1, ζ ≥ -0.01)."""


def mirror_undamped(A: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray] | None:
    """``A`` with its lightly unstable eigenvalues (``-0.01 <= ζ <= 0``) mirrored into the unit circle.

    Only for a model identified with a virtual spring (:mod:`bayesnsi.nsi.free_body`): an undamped
    virtual mode is expected there.

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
        conjugate pair); None when an unstable eigenvalue is damped more negatively than
        :data:`VIRTUAL_MODE_MAX_NEGATIVE_DAMPING`, is real, or A is defective.
    """
    lam, vec = np.linalg.eig(A)
    unstable = np.abs(lam) >= 1.0
    if not unstable.any():
        return A, lam[:0]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.log(lam.astype(complex)) / dt
        zeta = -s.real / np.abs(s)
    light = (np.abs(lam.imag) > 0) & (zeta >= -VIRTUAL_MODE_MAX_NEGATIVE_DAMPING)
    if np.any(unstable & ~light):
        return None
    mirrored = lam.copy()
    mirrored[unstable] = 1.0 / np.conj(lam[unstable])
    stable = np.real(vec @ np.diag(mirrored) @ np.linalg.inv(vec))
    if np.max(np.abs(np.linalg.eigvals(stable))) >= 1.0:  # defective A: the mirror did not hold
        return None
    return stable, lam[unstable & (lam.imag >= 0)]
