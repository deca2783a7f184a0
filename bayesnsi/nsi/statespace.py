"""Discrete-time state-space model with modal-form evaluation (SPEC sections 2 and 4).

``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k`` with sampling interval ``dt``.
Frequency responses and simulations use the eigendecomposition ``A = V Λ V⁻¹``: the FRF costs
O(n) per frequency and a simulation is n first-order recursive filters (``scipy.signal.lfilter``,
compiled), so long records are cheap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal as _signal

from ..exceptions import UnstableModelError

__all__ = ["StateSpaceModel", "modal_parameters_from_poles"]


def modal_parameters_from_poles(poles_continuous: np.ndarray):
    """Natural frequency [Hz] and damping ratio of continuous-time poles (SPEC section 4).

    ``s = -ζω_n ± jω_n√(1-ζ²)``: ``f_n = |s|/2π``, ``ζ = -Re(s)/|s|``.
    """
    s = np.asarray(poles_continuous, dtype=complex)
    mag = np.abs(s)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(mag > 0, -s.real / mag, np.nan)
    return mag / (2 * np.pi), zeta


@dataclass(frozen=True)
class StateSpaceModel:
    """Discrete-time state-space model.

    Attributes
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, n_inputs)
    C : ndarray, shape (n_outputs, n)
    D : ndarray, shape (n_outputs, n_inputs)
    dt : float
        Sampling interval [s].
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float

    @property
    def order(self) -> int:
        """State dimension n."""
        return self.A.shape[0]

    @property
    def poles_discrete(self) -> np.ndarray:
        """Eigenvalues of A."""
        return np.linalg.eigvals(self.A)

    @property
    def poles(self) -> np.ndarray:
        """Continuous-time poles ``log(λ)/dt`` (principal branch; SPEC Eq. 18 inverted)."""
        return np.log(self.poles_discrete.astype(complex)) / self.dt

    @property
    def is_stable(self) -> bool:
        """All discrete poles strictly inside the unit circle."""
        return bool(np.all(np.abs(self.poles_discrete) < 1.0))

    def _modal(self):
        lam, vec = np.linalg.eig(self.A)
        cond = np.linalg.cond(vec)
        if not np.isfinite(cond) or cond > 1e12:
            raise UnstableModelError(
                f"the identified A matrix is (nearly) defective (eigenvector condition {cond:.2g}); "
                "try another model order or number of block rows"
            )
        vinv = np.linalg.inv(vec)
        return lam, vec, vinv

    def frf(self, freqs_hz) -> np.ndarray:
        """Frequency response ``D + C (e^{jωdt} I - A)⁻¹ B`` (SPEC section 4, discrete form).

        Parameters
        ----------
        freqs_hz : array_like, shape (n_freq,)

        Returns
        -------
        ndarray, complex, shape (n_freq, n_outputs, n_inputs)
        """
        freqs = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
        lam, vec, vinv = self._modal()
        cm, bm = self.C @ vec, vinv @ self.B
        zf = np.exp(2j * np.pi * freqs * self.dt)
        resolvent = 1.0 / (zf[:, None] - lam[None, :])  # (n_freq, n)
        return np.einsum("on,fn,ni->foi", cm, resolvent, bm) + self.D[None]

    def continuous_state_matrix(self) -> np.ndarray:
        """``A_c = logm(A)/dt`` via the eigendecomposition (real part; SPEC Eq. 18 inverted)."""
        lam, vec, vinv = self._modal()
        ac = (vec * (np.log(lam.astype(complex)) / self.dt)) @ vinv
        return ac.real

    def simulate(self, inputs, x0=None) -> np.ndarray:
        """Response to an input sequence.

        Parameters
        ----------
        inputs : ndarray, shape (n_samples, n_inputs)
        x0 : ndarray, shape (n,), optional
            Initial state (zero by default).

        Returns
        -------
        ndarray, shape (n_samples, n_outputs)
        """
        u = np.asarray(inputs, dtype=float)
        lam, vec, vinv = self._modal()
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            drive = u @ (vinv @ self.B).T  # (N, n) modal inputs
            states = np.empty_like(drive, dtype=complex)
            for p, lp in enumerate(lam):
                # z[k+1] = λ z[k] + drive[k], z[0] = 0
                states[:, p] = _signal.lfilter([0.0, 1.0], [1.0, -lp], drive[:, p])
            y = (states @ (self.C @ vec).T).real + u @ self.D.T
            if x0 is not None:
                modal_x0 = vinv @ np.asarray(x0, dtype=float)
                powers = np.exp(np.arange(len(u))[:, None] * np.log(lam.astype(complex))[None, :])
                y += ((powers * modal_x0) @ (self.C @ vec).T).real
        if not np.all(np.isfinite(y)):
            raise UnstableModelError("simulation diverged: the model is unstable")
        return y

    def free_response(self, n_samples: int) -> np.ndarray:
        """Matrix mapping an initial state to the free response, shape (n_samples·l, n).

        Row block k is ``C A^k``.
        """
        lam, vec, vinv = self._modal()
        powers = np.exp(np.arange(n_samples)[:, None] * np.log(lam.astype(complex))[None, :])
        out = np.einsum("on,kn,nm->kom", self.C @ vec, powers, vinv).real
        return out.reshape(n_samples * self.C.shape[0], self.order)

    def state_trajectory(self, inputs, x0=None) -> np.ndarray:
        """State sequence x_k, shape (n_samples, n), from zero or a given initial state."""
        u = np.asarray(inputs, dtype=float)
        lam, vec, vinv = self._modal()
        drive = u @ (vinv @ self.B).T
        states = np.empty_like(drive, dtype=complex)
        zi0 = np.zeros(len(lam), dtype=complex) if x0 is None else vinv @ np.asarray(x0, dtype=float)
        for p, lp in enumerate(lam):
            zp, _ = _signal.lfilter([0.0, 1.0], [1.0, -lp], drive[:, p], zi=[zi0[p]])
            states[:, p] = zp
        return (states @ vec.T).real
