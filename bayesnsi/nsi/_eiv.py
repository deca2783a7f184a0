"""Errors in variables: B, D by prediction error with a Kalman predictor (docs/method.md §3 and 10).

The nonlinear inputs ``u_i = -n_i(y, ẏ)`` are built from *noisy* measured responses
(docs/method.md §10, "Errors in variables"). Written with the noise-free input ``u⁰``, the extended-input
model is::

    x_{k+1} = A x_k + B u_k + w_k,      w_k = -B (u_k - u⁰_k) ≈ -B_n J_k e_k
    y_k     = C x_k + D u_k + v_k

with ``e_k`` the measurement noise of the channels a term reads and ``J_k = ∂u/∂(y, ẏ)`` at
sample k. So the input noise is a *process noise* of known structure, correlated with the
measurement noise of the same sample (a term reading x13 uses the noise of output x13). The
output-error least squares of :mod:`._output_error` (K = 0) leaves that process noise, filtered
by the structure, in its residual: it correlates with the noisy regressors and biases B, hence
λ. When the structure is soft where the term acts (the beam, docs/method.md §8: ≈1.5 N/m at DOF 13),
this propagated noise dominates the residual.

Here B, D and x₀ minimise the one-step *prediction* error of the steady-state Kalman
predictor ``x̂_{k+1} = A x̂_k + B u_k + K (y_k - C x̂_k - D u_k)`` with A, C (and K) fixed.
That is linear in (B, D, x₀) — the predictor is the system ``(A - K C, B - K D, C, D)``
driven by u plus a known response to y — so it reuses the output-error machinery on
``ỹ = y - C ξ`` with ``ξ_{k+1} = (A - K C) ξ_k + K y_k``. The residual is then (close to) the
innovation, uncorrelated with the past noisy inputs. K comes from the Riccati equation with

- R = diag(σ_o²): white measurement noise per output, estimated from the data
  (:func:`measured_noise_std`) unless given;
- Q = B_n E[J Σ_e Jᵀ] B_nᵀ and the cross covariance S = E[w vᵀ] = -B_n E[J_o] σ_o² for
  output channels read by the terms (velocity channels: Q only);

with B from the previous pass (start: output error), iterated. The noisy inputs are also
corrected to second order, ``u - ½ Σ_c ∂²u/∂z_c² σ_c²`` (for x², x³ this is the Hermite
correction x² - σ², x³ - 3σ²x).

Damping is not improved by this step: it comes from A, i.e. from the subspace step, whose
inputs are as noisy as before. With a refined A (``NSIOptions.refine_poles``) C must be re-fitted
too: :func:`refine_prediction_error_bc` (``NSIOptions.c_method="prediction-error"``) alternates
this B step with C by least squares on the predictor's states. Measurements on the reference
cases: ``docs/measurements.md``, "NSI internals".
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import linalg as _linalg

from ..models import Term
from ..noise import measured_noise_std
from ..signals import _DIFFERENTIATORS, Signals
from ._output_error import refine_output_error
from .statespace import StateSpaceModel

__all__ = [
    "input_noise", "input_noise_covariances", "kalman_gain", "refine_prediction_error", "refine_prediction_error_bc",
]


def _channel_noise(signals: Signals, noise_std, velocity_method: str, velocity_std=None):
    """Noise std of every displacement and velocity channel the terms may read."""
    if noise_std is None or (velocity_std is None and signals.velocity is not None):
        measured_disp, measured_vel = measured_noise_std(signals)
    else:
        measured_disp, measured_vel = None, velocity_std
    disp = np.asarray(noise_std, dtype=float) if noise_std is not None else measured_disp
    if disp.shape != (len(signals.output_dofs),):
        raise ValueError(
            f"noise_std needs one value per output channel ({len(signals.output_dofs)}), got {disp.shape}"
        )
    if measured_vel is not None:
        vel = measured_vel
    else:  # derived by a finite-difference stencil: white noise times the stencil's norm
        vel = (
            disp * signals.fs * float(np.linalg.norm(_DIFFERENTIATORS[velocity_method]))
        )
    return disp, vel


def input_noise(
    signals: Signals,
    terms: Sequence[Term],
    noise_std=None,
    velocity_method: str = "fourth",
    velocity_std=None,
):
    """Sensitivity of the nonlinear inputs to measurement noise, and their second-order bias.

    Parameters
    ----------
    signals : Signals
    terms : sequence of Term
    noise_std : array_like, shape (l,), optional
        Noise std of each displacement channel; default :func:`white_noise_std`.
    velocity_method : str
        Differentiator used for velocities the signals do not carry.
    velocity_std : array_like, shape (l,), optional
        Noise std of each measured velocity channel when the caller has it (the second output of
        :func:`measured_noise_std`); estimated otherwise.

    Returns
    -------
    jac : list of (channel, ndarray (n_samples, q), float)
        For each read channel: the output index it is (or None for a velocity), ``∂u/∂z``
        (u = -n) at each sample, and the channel's noise variance.
    bias : ndarray, shape (n_samples, q)
        ``½ Σ_c ∂²u/∂z_c² σ_c²``, the expected shift of u caused by the noise (subtract it).
        Zero for discontinuous terms (containing sign()), where the Taylor expansion fails.
    """
    disp_std, vel_std = _channel_noise(signals, noise_std, velocity_method, velocity_std)
    column = {dof: c for c, dof in enumerate(signals.output_dofs)}
    x_dofs = sorted({d for t in terms for d in t.expr.displacement_dofs})
    v_dofs = sorted({d for t in terms for d in t.expr.velocity_dofs})
    x, v = signals.state_rows(x_dofs, v_dofs, velocity_method)
    channels: list[tuple[str, int, int | None, float]] = [("x", d, column[d], disp_std[column[d]]) for d in x_dofs]
    channels += [("v", d, None, vel_std[column[d]]) for d in v_dofs]
    n, q = signals.n_samples, len(terms)
    jac, bias = [], np.zeros((n, q))
    smooth = np.array([0.0 if "sign(" in t.expr.canonical else 1.0 for t in terms])
    for kind, dof, out_index, std in channels:
        store = x if kind == "x" else v
        base = store[dof - 1]
        h = max(std, 1e-6 * float(np.std(base)) or 1e-12)
        values = {}
        for sign in (-1, 1):
            store[dof - 1] = base + sign * h
            values[sign] = np.column_stack([-t.evaluate(x, v) for t in terms])
        store[dof - 1] = base
        centre = np.column_stack([-t.evaluate(x, v) for t in terms])
        jac.append((out_index, (values[1] - values[-1]) / (2 * h), std**2))
        bias += 0.5 * (values[1] - 2 * centre + values[-1]) / h**2 * std**2 * smooth
    return jac, bias


def input_noise_covariances(B_n, jac, n_outputs: int):
    """Process-noise covariance Q = B_n E[J Σ_e Jᵀ] B_nᵀ and cross covariance S = E[w vᵀ] (module notes)."""
    q_in = np.zeros((B_n.shape[1], B_n.shape[1]))
    cross = np.zeros((B_n.shape[1], n_outputs))
    for out_index, j, var in jac:
        q_in += (j.T @ j) / len(j) * var
        if out_index is not None:
            cross[:, out_index] -= j.mean(axis=0) * var
    return B_n @ q_in @ B_n.T, B_n @ cross


def kalman_gain(A, B_n, C, jac, R, extra=None):
    """Steady-state predictor gain K for the input-noise process noise (see the module notes).

    ``extra``: optional ``(Q, S, R)`` of further noise sources, added to those of the inputs.
    Returns ``(K, innovation covariance)``.
    """
    n = A.shape[0]
    Q, S = input_noise_covariances(B_n, jac, C.shape[0])
    if extra is not None:
        Q, S, R = Q + extra[0], S + extra[1], R + extra[2]
    # a tiny floor keeps the Riccati equation solvable when Q is rank deficient
    Q = 0.5 * (Q + Q.T) + 1e-12 * (np.trace(Q) / n + 1e-300) * np.eye(n)
    try:
        P = _linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)
    except (np.linalg.LinAlgError, ValueError):  # ill-conditioned pencil: iterate the Riccati recursion
        P = _riccati_iteration(A, C, Q, R, S)
    innovation = C @ P @ C.T + R
    K = np.linalg.solve(innovation.T, (A @ P @ C.T + S).T).T
    return K, 0.5 * (innovation + innovation.T)


def _riccati_iteration(A, C, Q, R, S, max_iter: int = 200_000, rtol: float = 1e-10):
    """Steady state of the Riccati difference equation of the predictor, started at P = Q.

    The fallback when the Schur method of :func:`scipy.linalg.solve_discrete_are` meets an
    ill-conditioned pencil (lightly damped modes with a nearly singular Q); it converges for a
    detectable (A, C), at the rate of the slowest predictor pole.
    """
    P = Q.copy()
    for _ in range(max_iter):
        gain = np.linalg.solve(C @ P @ C.T + R, (A @ P @ C.T + S).T).T
        new = A @ P @ A.T + Q - gain @ (A @ P @ C.T + S).T
        new = 0.5 * (new + new.T)
        if np.linalg.norm(new - P) <= rtol * max(float(np.linalg.norm(new)), 1e-300):
            return new
        P = new
    raise np.linalg.LinAlgError("the Riccati recursion did not converge")


def refine_prediction_error(
    A,
    C,
    u,
    y,
    dt,
    signals: Signals,
    terms: Sequence[Term],
    zero_feedthrough: bool = True,
    noise_std=None,
    velocity_method: str = "fourth",
    iterations: int = 3,
    output_weights=None,
):
    """B, D, x₀ by prediction error with a Kalman predictor accounting for input noise.

    Parameters
    ----------
    A, C : ndarray
        From the subspace step (kept fixed).
    u : ndarray, shape (N, m + q)
        Extended input built from the measured (noisy) signals; the last q columns are the
        nonlinear inputs.
    y : ndarray, shape (N, l)
        Measured outputs.
    dt : float
    signals : Signals
        The measured data (to differentiate the terms with respect to the noisy channels).
    terms : sequence of Term
    zero_feedthrough : bool
    noise_std : array_like, shape (l,), optional
        Measurement-noise std of each displacement channel [m]; default estimated by
        :func:`white_noise_std`.
    velocity_method : str
    iterations : int
        Passes of (K from B, then B from K).
    output_weights : ndarray, shape (l,), optional
        As in :func:`refine_output_error` for the first (output-error) pass; the prediction-error
        passes whiten the residual with the innovation covariance.

    Returns
    -------
    B, D, x0, K : ndarray
        K is the predictor gain of the last pass.
    """
    B, _, D, x0, K = _prediction_error_passes(
        A, C, u, y, dt, signals, terms, zero_feedthrough, noise_std, velocity_method,
        iterations, output_weights, refit_c=False,
    )
    return B, D, x0, K


def refine_prediction_error_bc(
    A,
    C,
    u,
    y,
    dt,
    signals: Signals,
    terms: Sequence[Term],
    zero_feedthrough: bool = True,
    noise_std=None,
    velocity_method: str = "fourth",
    iterations: int = 6,
    output_weights=None,
):
    """B, C, D, x₀ with A fixed: prediction-error B alternated with C from the predicted states.

    When A does not come with its own C (e.g. after :func:`bayesnsi.nsi._output_error.refine_poles`
    changed its eigenvalues), the subspace C no longer matches it: the subspace model's other
    modes compensated the errors of its own poles, not of these. Here C is re-estimated
    for the given A: with the steady-state Kalman predictor of :func:`refine_prediction_error`,
    ``y_k = C x̂_k + D u_k + ε_k`` where the one-step prediction ``x̂_k`` uses data up to k-1
    only, so the innovation ε_k is uncorrelated with it and the row-wise least squares for C
    is consistent (an output-error state, simulated from the noisy inputs, would carry the
    propagated input noise as errors in the regressors). Each pass: K from (A, B, C), B (and D)
    by prediction error, then C by least squares on ``x̂`` (D kept); the last pass ends with B.

    Parameters
    ----------
    As :func:`refine_prediction_error`; ``iterations`` counts passes (each re-estimates K, B
    and, except the last, C).

    Returns
    -------
    B, C, D, x0, K : ndarray
    """
    return _prediction_error_passes(
        A, C, u, y, dt, signals, terms, zero_feedthrough, noise_std, velocity_method,
        iterations, output_weights, refit_c=True,
    )


def _predicted_states(F, B_u, K, u, y, dt):
    """One-step predicted states ``x̂_{k+1} = F x̂_k + B_u u_k + K y_k``, ``x̂_0 = 0``, shape (N, n)."""
    n = F.shape[0]
    inputs = np.hstack([u, y])
    return StateSpaceModel(
        A=F, B=np.hstack([B_u, K]), C=np.eye(n), D=np.zeros((n, inputs.shape[1])), dt=dt
    ).simulate(inputs)


def _prediction_error_passes(
    A, C, u, y, dt, signals, terms, zero_feedthrough, noise_std, velocity_method, iterations,
    output_weights, refit_c,
):
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    C = np.array(C, dtype=float)
    m_all, q = u.shape[1], len(terms)
    disp_std, _ = _channel_noise(signals, noise_std, velocity_method)
    if q == 0 and not refit_c:
        B, D, x0 = refine_output_error(A, C, u, y, dt, zero_feedthrough, output_weights)
        return B, C, D, x0, np.zeros((A.shape[0], C.shape[0]))
    u = u.copy()
    if q:
        jac, bias = input_noise(signals, terms, disp_std, velocity_method)
        u[:, m_all - q :] -= bias
    else:
        jac = []
    R = np.diag(np.maximum(disp_std, 1e-12 * np.abs(y).max(axis=0)) ** 2)
    B, D, x0 = refine_output_error(A, C, u, y, dt, zero_feedthrough, output_weights)
    K = np.zeros((A.shape[0], C.shape[0]))
    B_noise = B[:, m_all - q :]
    passes = max(1, int(iterations))
    for index in range(passes):
        K, innovation = kalman_gain(A, B_noise if q else np.zeros((A.shape[0], 1)), C, jac, R)
        F = A - K @ C
        # ξ_{k+1} = F ξ_k + K y_k: the predictor's response to the measured outputs
        predicted = StateSpaceModel(
            A=F, B=K, C=C, D=np.zeros((C.shape[0], C.shape[0])), dt=dt
        ).simulate(y)
        whiten = np.linalg.inv(np.linalg.cholesky(innovation))
        # ỹ = y - C ξ = C (zI - F)⁻¹ (B - K D) u + D u + innovation
        B_pred, D, x0 = refine_output_error(
            F, whiten @ C, u, (y - predicted) @ whiten.T, dt, zero_feedthrough, None
        )
        D = np.linalg.solve(whiten, D)
        B = B_pred + K @ D
        B_noise = B[:, m_all - q :]
        if refit_c and index < passes - 1:
            states = _predicted_states(F, B - K @ D, K, u, y, dt)
            radius = float(np.max(np.abs(np.linalg.eigvals(F))))
            settle = np.log(1e-6) / np.log(radius) if radius < 1 else np.inf
            skip = int(min(np.ceil(settle), len(y) // 10))
            target = y[skip:] - u[skip:] @ D.T
            C = np.linalg.lstsq(states[skip:], target, rcond=None)[0].T
    return B, C, D, x0, K
