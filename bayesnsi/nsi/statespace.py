"""Discrete-time state-space model with modal-form evaluation (docs/method.md §2 and 4).

``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k`` with sampling interval ``dt``.
Frequency responses and simulations use the eigendecomposition ``A = V Λ V⁻¹``: the FRF costs
O(n) per frequency and a simulation is one compiled first-order recursion per mode, one of each
complex-conjugate pair (:func:`modal_filter`, a LAPACK banded triangular solve), so long records
are cheap (timings in ``docs/measurements.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import UnstableModelError
from ._recursion import delayed_first_order

__all__ = ["StateSpaceModel", "modal_filter", "modal_filter_step", "modal_parameters_from_poles"]


def modal_filter(eigenvalue: complex, signal: np.ndarray):
    """``z_{k+1} = λ z_k + u_k``, ``z_0 = 0`` for a real signal (along axis 0).

    The first-order recursion is a banded triangular solve (LAPACK ``ztbtrs``,
    :mod:`bayesnsi.nsi._recursion`): faster than ``scipy.signal.lfilter``'s complex recursion and
    than its real second-order form (which also lost digits near ``z = 1``), and no import of
    ``scipy.signal`` (0.3-0.7 s at the start of a command).

    Parameters
    ----------
    eigenvalue : complex
    signal : ndarray, real, shape (N, ...)

    Returns
    -------
    ndarray, complex (or real for a real eigenvalue), shape (N, ...)
    """
    out, _ = modal_filter_step(complex(eigenvalue), np.asarray(signal, dtype=float), None)
    return out


def decay_lengths(eigenvalues, n_samples: int) -> np.ndarray:
    """Samples after which ``|λ|^k`` falls below ``2⁻⁶⁰`` (beneath the rounding of the first terms).

    A free response ``λ^k z₀`` or a weighted sum ``Σ_k λ^k r_k`` is exact to rounding when cut there:
    a heavily damped mode (e.g. of a Kalman predictor) needs a fraction of a long record.

    Parameters
    ----------
    eigenvalues : array_like of complex
    n_samples : int

    Returns
    -------
    ndarray of int
        One length per eigenvalue, between 1 and ``n_samples``.
    """
    radius = np.abs(np.asarray(eigenvalues, dtype=complex))
    with np.errstate(divide="ignore"):
        decay = -np.log(radius)
    needed = np.where(decay > 0, np.ceil(60.0 * np.log(2.0) / np.where(decay > 0, decay, 1.0)) + 1, n_samples)
    return np.clip(needed, 1, max(n_samples, 1)).astype(int)


def modal_filter_step(lam: complex, u: np.ndarray, state):
    """One chunk of :func:`modal_filter`: ``(filtered, state)``.

    Pass the returned ``state`` with the next chunk of the same signal (``None``: at rest), so a
    long record is filtered chunk by chunk with memory independent of its length.

    Parameters
    ----------
    lam : complex
        The eigenvalue λ.
    u : ndarray, real, shape (N, ...)
        This chunk of the signal.
    state : object or None
        What the previous chunk returned (the recursion's memory), or None at the start.

    Returns
    -------
    filtered : ndarray, complex (real for a real λ), shape (N, ...)
    state : object
        To pass with the next chunk.
    """
    real = lam.imag == 0.0
    coef = lam.real if real else lam
    zi = np.zeros((1,) + u.shape[1:], dtype=float if real else complex) if state is None else state
    return delayed_first_order(coef, u, zi)  # lfilter([0, 1], [1, -coef]), without importing scipy.signal


def modal_parameters_from_poles(poles_continuous: np.ndarray):
    """Natural frequency [Hz] and damping ratio of continuous-time poles (docs/method.md §4).

    ``s = -ζω_n ± jω_n√(1-ζ²)``: ``f_n = |s|/2π``, ``ζ = -Re(s)/|s|``.

    Parameters
    ----------
    poles_continuous : array_like of complex
        Poles s [rad/s].

    Returns
    -------
    frequency_hz, damping_ratio : ndarray
        Same shape as the poles.
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
        """Continuous-time poles ``log(λ)/dt`` (principal branch; paper Eq. 18 inverted)."""
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
        """Frequency response ``D + C (e^{jωdt} I - A)⁻¹ B`` (docs/method.md §4, discrete form).

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
        """Continuous-time state matrix ``A_c = logm(A)/dt`` (paper Eq. 18 inverted).

        Returns
        -------
        ndarray, shape (n, n)
            Real part of the eigendecomposition-based logarithm.
        """
        lam, vec, vinv = self._modal()
        ac = (vec * (np.log(lam.astype(complex)) / self.dt)) @ vinv
        return ac.real

    def _modal_half(self):
        """One eigenvalue of each complex-conjugate pair plus the real ones, with weights.

        A real system's conjugate modes respond to a real input with conjugate states, so
        ``y = Σ_p w_p Re(C v_p z_p)`` over the kept modes with ``w = 2`` for a pair and 1 for a
        real mode: half the recursions of the full modal sum.
        """
        lam, vec, vinv = self._modal()
        upper, lower, real = lam.imag > 0, lam.imag < 0, lam.imag == 0
        if np.count_nonzero(upper) != np.count_nonzero(lower) or not np.allclose(
            np.sort_complex(lam[upper]), np.sort_complex(np.conj(lam[lower]))
        ):
            return lam, vec, vinv, np.ones(len(lam))  # not in exact conjugate pairs: full sum
        keep = upper | real
        return lam[keep], vec[:, keep], vinv[keep], np.where(real[keep], 1.0, 2.0)

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
        lam, vec, vinv, weight = self._modal_half()
        modal_b, cm = vinv @ self.B, self.C @ vec * weight
        k = len(lam)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            # modal drives d_p = (V⁻¹B)_p u, column-contiguous: one complex column per mode
            drive = np.asfortranarray(u @ modal_b.T)
            basis = np.empty((u.shape[0], 2 * k), order="F")  # [Re z, Im z] of the modal states
            for p, lp in enumerate(lam):
                state, _ = delayed_first_order(lp if lp.imag else lp.real, drive[:, p])
                basis[:, p] = state.real
                basis[:, k + p] = state.imag if np.iscomplexobj(state) else 0.0
            y = basis @ np.vstack([cm.real.T, -cm.imag.T]) + u @ self.D.T
            if x0 is not None:
                y += self.initial_response(x0, len(u))
        if not np.all(np.isfinite(y)):
            raise UnstableModelError("simulation diverged: the model is unstable")
        return y

    def simulate_each(self, inputs) -> np.ndarray:
        """Response to each input column on its own (zero initial state).

        Parameters
        ----------
        inputs : ndarray, shape (n_samples, n_inputs)

        Returns
        -------
        ndarray, shape (n_samples, n_outputs, n_inputs)
            ``[:, :, c]`` is the response to column c alone (the sum over c is :meth:`simulate`).
        """
        u = np.asarray(inputs, dtype=float)
        lam, vec, vinv, weight = self._modal_half()
        modal_b, cm = vinv @ self.B, self.C @ vec * weight  # (k, inputs), (l, k)
        k = len(lam)
        y = np.empty((u.shape[0], self.C.shape[0], u.shape[1]))
        basis = np.empty((u.shape[0], 2 * k), order="F")  # [Re F, Im F] of one input column, F = 1/(z - λ)
        with np.errstate(over="ignore", invalid="ignore"):
            for c in range(u.shape[1]):  # one column at a time: memory O(N n), not O(N n m)
                for p, lp in enumerate(lam):
                    filtered = modal_filter(lp, u[:, c])
                    basis[:, p] = filtered.real
                    basis[:, k + p] = filtered.imag if np.iscomplexobj(filtered) else 0.0
                gain = cm * modal_b[:, c]  # Re(g F) = Re g Re F - Im g Im F
                y[:, :, c] = basis @ np.vstack([gain.real.T, -gain.imag.T])
                y[:, :, c] += u[:, c : c + 1] * self.D[:, c]
        if not np.all(np.isfinite(y)):
            raise UnstableModelError("simulation diverged: the model is unstable")
        return y

    def initial_response(self, x0, n_samples: int) -> np.ndarray:
        """Free response ``C A^k x₀`` for k = 0..n_samples-1.

        Parameters
        ----------
        x0 : array_like, shape (n,)
            Initial state.
        n_samples : int
            Length of the response.

        Returns
        -------
        ndarray, shape (n_samples, n_outputs)
        """
        lam, vec, vinv, weight = self._modal_half()
        lengths = decay_lengths(lam, n_samples)
        impulse = np.zeros(int(np.max(lengths, initial=0)))
        impulse[:1] = 1.0
        modal_x0 = vinv @ np.asarray(x0, dtype=float)
        states = np.zeros((n_samples, len(lam)), dtype=complex)
        for p, lp in enumerate(lam):
            # λ^k = λ · (response of 1/(z - λ) to a unit impulse at k = 0)[k] for k >= 1, until below 2^-60
            states[: lengths[p], p] = modal_filter(lp, impulse[: lengths[p]]) * (lp * modal_x0[p])
            states[0, p] = modal_x0[p]
        return (states @ (self.C @ vec * weight).T).real

    def free_response(self, n_samples: int) -> np.ndarray:
        """Matrix mapping an initial state to the free response (row block k is ``C A^k``).

        Parameters
        ----------
        n_samples : int
            Length of the response.

        Returns
        -------
        ndarray, shape (n_samples·l, n)
        """
        lam, vec, vinv = self._modal()
        powers = np.exp(np.arange(n_samples)[:, None] * np.log(lam.astype(complex))[None, :])
        out = np.einsum("on,kn,nm->kom", self.C @ vec, powers, vinv).real
        return out.reshape(n_samples * self.C.shape[0], self.order)

    def state_trajectory(self, inputs, x0=None) -> np.ndarray:
        """State sequence x_k driven by ``inputs`` from zero or a given initial state.

        Parameters
        ----------
        inputs : array_like, shape (n_samples, m)
            Input sequence.
        x0 : array_like, shape (n,), optional
            Initial state (default zero).

        Returns
        -------
        ndarray, shape (n_samples, n)
        """
        u = np.asarray(inputs, dtype=float)
        lam, vec, vinv = self._modal()
        drive = u @ (vinv @ self.B).T
        states = np.empty_like(drive, dtype=complex)
        zi0 = np.zeros(len(lam), dtype=complex) if x0 is None else vinv @ np.asarray(x0, dtype=float)
        for p, lp in enumerate(lam):
            zp, _ = delayed_first_order(lp, drive[:, p], [zi0[p]])
            states[:, p] = zp
        return (states @ vec.T).real
