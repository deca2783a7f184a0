"""Innovation (Kalman predictor) form of an identified model (docs/method.md §10).

The identified extended-input model is deterministic: ``x_{k+1} = A x_k + B u_k``,
``y_k = C x_k + D u_k``. The data add noise: the measurement noise ``v`` of the outputs, the
process noise ``w = -B_n J e`` that the noisy nonlinear inputs carry (errors in variables,
:mod:`bayesnsi.nsi._eiv`) and, optionally, an unmeasured white force at the input DOFs. With
their covariances ``Q = E[w wᵀ]``, ``R = E[v vᵀ]``, ``S = E[w vᵀ]`` the steady-state Kalman
predictor

    x̂_{k+1} = A x̂_k + B u_k + K ε_k,      y_k = C x̂_k + D u_k + ε_k,

has the gain ``K = (A P Cᵀ + S)(C P Cᵀ + R)⁻¹`` with ``P`` the stabilising solution of the
discrete algebraic Riccati equation (:func:`scipy.linalg.solve_discrete_are`) and white
innovations ``ε`` of covariance ``C P Cᵀ + R``. This is the likelihood the evidence uses with
``[evidence] residual = "prediction"`` (:func:`bayesnsi.nsi.predictor_reconstruction`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError, UnstableModelError
from ..signals import Signals
from .statespace import StateSpaceModel

__all__ = ["InnovationForm", "innovation_form"]


@dataclass(frozen=True)
class InnovationForm:
    """The identified model with its steady-state Kalman gain.

    Attributes
    ----------
    model : StateSpaceModel
        The identified extended-input model ``(A, B, C, D, dt)`` (inputs: forces, then the
        nonlinear inputs ``-n_i``).
    gain : ndarray, shape (n, l)
        Kalman gain K.
    innovation_covariance : ndarray, shape (l, l)
        ``C P Cᵀ + R``, the covariance of the innovations ε.
    process_covariance, measurement_covariance, cross_covariance : ndarray
        Q (n, n), R (l, l) and S (n, l) the gain was computed from.
    """

    model: StateSpaceModel
    gain: np.ndarray
    innovation_covariance: np.ndarray
    process_covariance: np.ndarray
    measurement_covariance: np.ndarray
    cross_covariance: np.ndarray

    @property
    def predictor(self) -> StateSpaceModel:
        """One-step predictor ``(A - K C, [B - K D, K], C, [D, 0])`` driven by ``[u, y]``."""
        A, B, C, D, K = self.model.A, self.model.B, self.model.C, self.model.D, self.gain
        zeros = np.zeros((C.shape[0], C.shape[0]))
        return StateSpaceModel(A - K @ C, np.hstack([B - K @ D, K]), C, np.hstack([D, zeros]), self.model.dt)

    def innovations(self, inputs, outputs) -> np.ndarray:
        """One-step prediction errors ``ε_k = y_k - ŷ_{k|k-1}`` (predictor started at x̂₀ = 0).

        Parameters
        ----------
        inputs : ndarray, shape (n_samples, m + q)
            Extended input (:meth:`bayesnsi.nsi.NSIResult.extended_input`).
        outputs : ndarray, shape (n_samples, l)
            Measured outputs.

        Returns
        -------
        ndarray, shape (n_samples, l)
        """
        u, y = np.asarray(inputs, dtype=float), np.asarray(outputs, dtype=float)
        return y - self.predictor.simulate(np.hstack([u, y]))


def innovation_form(result, signals: Signals, noise_std=None, force_noise_std=None) -> InnovationForm:
    """The Kalman gain and innovation covariance of ``result`` for the noise of ``signals``.

    Parameters
    ----------
    result : NSIResult
        Identified at the data's rate (``result.upsample == 1``).
    signals : Signals
        The data (their measurement noise is estimated from them unless ``noise_std`` is given).
    noise_std : array_like, shape (l,), optional
        Measurement-noise std of each displacement channel; default
        :func:`bayesnsi.nsi._noise.measured_noise_std`.
    force_noise_std : array_like, shape (m,), optional
        Std of an unmeasured white force at each input DOF (process noise through the force
        columns of B); default none.

    Returns
    -------
    InnovationForm

    Raises
    ------
    InputDataError
        For a result identified on an upsampled grid, or noise stds of the wrong shape.
    UnstableModelError
        When no stabilising gain exists.
    """
    from scipy import linalg as _linalg

    from ..noise import measured_noise_std
    from ._eiv import input_noise, kalman_gain

    if result.upsample != 1:
        raise InputDataError(
            f"candidate {result.candidate.name!r} was identified on a grid {result.upsample}x finer than the data; "
            "its one-step predictor at the data's rate is bayesnsi.nsi.predictor_reconstruction"
        )
    model, m = result.model, len(result.input_dofs)
    y = np.asarray(signals.displacement, dtype=float)
    noise = measured_noise_std(signals)[0] if noise_std is None else np.asarray(noise_std, dtype=float)
    force = np.zeros(m) if force_noise_std is None else np.asarray(force_noise_std, dtype=float)
    if noise.shape != (y.shape[1],) or force.shape != (m,):
        raise InputDataError(
            f"noise_std needs {y.shape[1]} values and force_noise_std {m}, got shapes {noise.shape} and {force.shape}"
        )
    jac, _ = input_noise(signals, result.terms, noise, result.options.velocity_method)
    R = np.diag(np.maximum(noise, 1e-12 * np.abs(y).max(axis=0)) ** 2)
    b_f, d_f, var_f = model.B[:, :m], model.D[:, :m], np.diag(force**2)
    extra = (b_f @ var_f @ b_f.T, b_f @ var_f @ d_f.T, d_f @ var_f @ d_f.T)
    b_n = model.B[:, m:] if model.B.shape[1] > m else np.zeros((model.A.shape[0], 1))
    try:
        K, innovation = kalman_gain(model.A, b_n, model.C, jac, R, extra)
    except (np.linalg.LinAlgError, ValueError, _linalg.LinAlgError) as err:
        raise UnstableModelError(f"candidate {result.candidate.name!r}: no stabilising Kalman gain ({err})") from None
    from ._eiv import input_noise_covariances

    Q, S = input_noise_covariances(b_n, jac, y.shape[1])
    return InnovationForm(model, K, innovation, Q + extra[0], R + extra[2], S + extra[1])
