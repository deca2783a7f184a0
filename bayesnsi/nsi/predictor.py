"""One-step-ahead (innovations) form of the affine reconstruction (docs/method.md §6 and 10)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..exceptions import UnstableModelError
from ..signals import Signals
from .reconstruct import AffineReconstruction, initial_state
from .statespace import StateSpaceModel

__all__ = ["predictor_reconstruction"]


def predictor_reconstruction(result, signals: Signals, noise_std=None) -> AffineReconstruction:
    """One-step-ahead (innovations) form of the affine reconstruction (docs/method.md §6 and 10).

    The nonlinear inputs are built from *noisy* measurements, so the model is really
    ``x_{k+1} = A x_k + B u_k + w_k`` with a process noise ``w = -B_n J e`` of known structure
    (errors in variables, :mod:`bayesnsi.nsi._eiv`). Its exact Gaussian likelihood is that of
    the innovations of the steady-state Kalman predictor ``x̂_{k+1} = A x̂_k + B u_k +
    K (y_k - C x̂_k - D u_k)``, which is affine in the coefficients for a fixed gain ``K``:
    ``y - ŷ(λ) = ε(λ)`` with ``ŷ(λ) = ŷ₀ + Σ_i λ_i g_i`` where ``ŷ₀`` is the predictor's response
    to the forces and the measured outputs and ``g_i`` its response to the unit input ``-n_i``
    through ``(A - K C, b_i - K d_i, C, d_i)``. ``K`` comes from the Riccati equation with the
    measurement noise per channel (estimated from the data unless given) and the input-noise
    process noise of this candidate's own terms. An open-loop residual counts the input noise
    that the resonances amplify as misfit, which a spurious extra term can absorb (docs/method.md §10:
    the negative-stiffness superset); the innovations do not. The gain needs the noise level of
    every channel a term reads (:func:`bayesnsi.nsi._noise.measured_noise_std`); an overestimated
    velocity noise makes the innovations anti-correlated (measurements in
    ``docs/measurements.md``).

    For a result identified on an upsampled grid (``upsample = R``) the predictor runs at the
    data's samples on the lifted model ``(A^R, Σ_j A^{R-1-j} B)``: the inputs between two samples
    enter through ``Σ_j A^{R-1-j} B u_{kR+j}``.

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        The data the result was identified from (at the data's own rate).
    noise_std : array_like, shape (l,), optional
        Measurement-noise std of each displacement channel; default
        :func:`bayesnsi.nsi._noise.measured_noise_std`.

    Returns
    -------
    AffineReconstruction
        ``measured - predict(λ)`` are the innovations.

    Raises
    ------
    NotIdentifiableError
        When an estimated coefficient is exactly zero.
    UnstableModelError
        When no stabilising predictor gain exists for the identified model.
    """
    from scipy import linalg as _linalg

    from ..exceptions import NotIdentifiableError
    from ..noise import measured_noise_std
    from ._eiv import input_noise, kalman_gain

    if signals.realisations > 1:  # each realisation's predictor starts afresh: no state across a boundary
        noise_std = measured_noise_std(signals)[0] if noise_std is None else noise_std
        parts = [predictor_reconstruction(result, one, noise_std) for one in signals.realisation_records()]
        joined = (np.concatenate([getattr(p, k) for p in parts]) for k in ("measured", "baseline", "signatures"))
        return replace(parts[0], **dict(zip(("measured", "baseline", "signatures"), joined)))  # type: ignore[arg-type]
    model = result.model
    m = len(result.input_dofs)
    estimate = result.coefficient_values
    if np.any(estimate == 0):
        raise NotIdentifiableError("a coefficient estimate is exactly zero; its per-unit signature is undefined")
    factor = result.upsample
    u = result.extended_input(signals)
    y = np.asarray(signals.displacement, dtype=float)
    n_samples, n_out = y.shape
    A, B, C, D = model.A, model.B, model.C, model.D
    powers = [np.eye(A.shape[0])]
    for _ in range(factor - 1):
        powers.append(A @ powers[-1])
    lifted_b = [powers[factor - 1 - j] @ B for j in range(factor)]  # input at fine step j of an interval
    a_data = powers[-1] @ A  # A^R: one data sample
    velocity_noise = None
    if noise_std is None:
        noise, velocity_noise = measured_noise_std(signals)
    else:
        noise = np.asarray(noise_std, dtype=float)
    jac, _ = input_noise(signals, result.terms, noise, result.options.velocity_method,
                         velocity_std=velocity_noise)
    measurement = np.diag(np.maximum(noise, 1e-12 * np.abs(y).max(axis=0)) ** 2)
    try:
        K, _ = kalman_gain(a_data, sum(lb[:, m:] for lb in lifted_b), C, jac, measurement)
    except (np.linalg.LinAlgError, ValueError, _linalg.LinAlgError) as err:
        raise UnstableModelError(
            f"candidate {result.candidate.name!r}: no stabilising Kalman predictor for the identified model ({err}); "
            "use the open-loop residual ([evidence] residual = \"reconstruction\")"
        ) from None
    closed = a_data - K @ C

    def predictor(columns, extra_b=None):
        """The predictor driven by the columns of u (and ``extra_b`` times y), with its input record.

        An interval's fine samples enter side by side through ``A^{R-1-j} B``; the one at the data's
        instant (j = 0) also reaches the output through D, so the gain feeds it back by ``-K D``.
        """
        width = len(columns)
        inputs = u[: n_samples * factor, columns].reshape(n_samples, factor * width)
        b = np.hstack([lifted_b[j][:, columns] for j in range(factor)])
        b[:, :width] -= K @ D[:, columns]
        d = np.zeros((n_out, factor * width))
        d[:, :width] = D[:, columns]
        if extra_b is not None:
            inputs, b, d = np.hstack([inputs, y]), np.hstack([b, extra_b]), np.hstack([d, np.zeros((n_out, n_out))])
        return StateSpaceModel(closed, b, C, d, model.dt * factor), inputs

    # the forces and the measured outputs drive the same predictor: one simulation
    by_forces, inputs = predictor(list(range(m)), extra_b=K)
    baseline = by_forces.simulate(inputs)
    q = u.shape[1] - m
    signatures = np.empty(y.shape + (q,))
    for i in range(q):
        by_term, inputs = predictor([m + i])
        signatures[:, :, i] = by_term.simulate(inputs) / estimate[i]
    # initial state of the predictor by least squares (its transient decays at the rate of A - KC)
    fitted = baseline + signatures @ estimate
    x0 = initial_state(by_forces, None, y - fitted, forced=np.zeros_like(y))
    baseline = baseline + by_forces.initial_response(x0, n_samples)
    return AffineReconstruction.of_result(result, y, baseline, signatures)
