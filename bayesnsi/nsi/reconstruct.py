"""Open- and closed-loop reconstruction of an identified candidate (SPEC section 5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import UnstableModelError
from ..signals import Signals
from .statespace import StateSpaceModel

_FIXED_POINT_ITERATIONS = 4

__all__ = ["Reconstruction", "reconstruct", "nrmse", "initial_state", "AffineReconstruction", "affine_reconstruction"]


def nrmse(measured: np.ndarray, predicted: np.ndarray):
    """NRMSE per channel ``rms(y - ŷ)/rms(y)`` and overall (RMS over channels), SPEC 5.

    Returns
    -------
    per_channel : ndarray, shape (l,)
    overall : float
    """
    y = np.asarray(measured, dtype=float).reshape(len(measured), -1)
    e = y - np.asarray(predicted, dtype=float).reshape(y.shape)
    per = np.sqrt(np.mean(e**2, axis=0) / np.mean(y**2, axis=0))
    return per, float(np.sqrt(np.mean(per**2)))


@dataclass(frozen=True)
class Reconstruction:
    """Reconstructed response of one candidate.

    Attributes
    ----------
    measured : ndarray, shape (n_samples, l)
    predicted : ndarray, shape (n_samples, l)
    closed_loop : bool
        False: driven by the extended input built from the measured data (the paper's
        "reconstructed signal"); True: nonlinear inputs from the model's own output.
    x0 : ndarray, shape (n,)
        Initial state (least squares).
    nrmse_per_channel : ndarray, shape (l,)
    nrmse : float
    """

    measured: np.ndarray
    predicted: np.ndarray
    closed_loop: bool
    x0: np.ndarray
    nrmse_per_channel: np.ndarray
    nrmse: float

    @property
    def residual(self) -> np.ndarray:
        """``y - ŷ``, shape (n_samples, l)."""
        return self.measured - self.predicted

    @property
    def rmse(self) -> np.ndarray:
        """RMS error per channel, in the output's units."""
        return np.sqrt(np.mean(self.residual**2, axis=0))


def initial_state(model: StateSpaceModel, inputs: np.ndarray, outputs: np.ndarray) -> np.ndarray:
    """Least-squares initial state for a given input/output record.

    Minimises ``Σ_k ‖y_k - ŷ_k^{forced} - C A^k x₀‖²``. The normal matrix
    ``Σ_k (C A^k)ᵀ C A^k`` is summed in closed form in modal coordinates (geometric series), so
    the cost is O(N n l), not O(N n² l).
    """
    forced = model.simulate(inputs)
    residual = np.asarray(outputs, dtype=float) - forced
    lam, vec = np.linalg.eig(model.A)
    vinv = np.linalg.inv(vec)
    cm = model.C @ vec
    n_samples = len(residual)
    prod = lam[:, None] * lam[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        series = np.where(np.abs(1 - prod) > 1e-12, (1 - prod**n_samples) / (1 - prod), n_samples)
    normal = (vinv.T @ ((cm.T @ cm) * series) @ vinv).real
    log_lam = np.log(lam.astype(complex))
    # Σ_k λ_p^k (r_k · Cm[:, p]) accumulated in chunks to bound memory.
    weighted = np.zeros(len(lam), dtype=complex)
    chunk = 16384
    for start in range(0, n_samples, chunk):
        stop = min(start + chunk, n_samples)
        powers = np.exp(np.arange(start, stop)[:, None] * log_lam[None, :])
        weighted += np.sum(powers * (residual[start:stop] @ cm), axis=0)
    rhs = (vinv.T @ weighted).real
    return np.linalg.lstsq(normal, rhs, rcond=None)[0]


def reconstruct(result, signals: Signals, closed_loop: bool = False, n_init: int | None = None) -> Reconstruction:
    """Reconstruct the measured response with an identified candidate (SPEC section 5).

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        Data to reconstruct (estimation or validation data).
    closed_loop : bool
        Open loop (default): the model driven by ``[f, -n_i(y_measured)]``. Closed loop: the
        nonlinear inputs evaluated on the model's own simulated displacements and velocities
        (velocity output ``C A_c x``), needed for validation data.
    n_init : int, optional
        Samples used to estimate the initial state (default: all for open loop, 50 for closed
        loop, as in the Silverbox benchmark rules).

    Raises
    ------
    UnstableModelError
        When the closed-loop simulation diverges (a wrong model can be unstable in feedback).
    """
    model = result.model
    factor = getattr(result, "upsample", 1)  # identified on a finer grid: work there, compare at the data's samples
    work = result.working_signals(signals) if factor > 1 else signals
    u = result.extended_input(signals)
    y_work = np.asarray(work.displacement)
    init = len(y_work) if n_init is None and not closed_loop else min((n_init or 50) * factor, len(y_work))
    x0 = initial_state(model, u[:init], y_work[:init])
    if not closed_loop:
        predicted = model.simulate(u, x0)
    else:
        predicted = _closed_loop(result, work, x0)
    y = np.asarray(signals.displacement)
    predicted = predicted[::factor]
    per, overall = nrmse(y, predicted)
    return Reconstruction(
        measured=y, predicted=predicted, closed_loop=closed_loop, x0=x0, nrmse_per_channel=per, nrmse=overall
    )


def _closed_loop(result, signals: Signals, x0: np.ndarray) -> np.ndarray:
    """Simulate with the nonlinear inputs fed back from the model's own output."""
    model = result.model
    terms = result.terms
    m = len(result.input_dofs)
    A, B, C, D = model.A, model.B, model.C, model.D
    c_vel = C @ model.continuous_state_matrix()
    force = np.asarray(signals.force)
    n_samples, n_out = len(force), C.shape[0]
    n_dofs = max([signals.n_dofs] + [max(t.dofs) for t in terms])
    rows = np.array(result.output_dofs) - 1
    b_force, b_nl = B[:, :m], B[:, m:]
    d_force, d_nl = D[:, :m], D[:, m:]
    implicit = bool(np.any(d_nl != 0))  # y_k depends on n(y_k): solve by fixed-point iteration
    out = np.empty((n_samples, n_out))
    x = np.array(x0, dtype=float)
    xs = np.full(n_dofs, np.nan)
    vs = np.full(n_dofs, np.nan)
    bound = 1e6 * max(1.0, float(np.max(np.abs(signals.displacement))))
    nl = np.zeros(len(terms))
    for k in range(n_samples):
        linear_part = C @ x + d_force @ force[k]
        vs[rows] = c_vel @ x
        for _ in range(_FIXED_POINT_ITERATIONS if implicit else 1):
            yk = linear_part - d_nl @ nl if implicit else linear_part
            xs[rows] = yk
            for idx, term in enumerate(terms):
                nl[idx] = float(term.expr.function(xs, vs))
        out[k] = yk
        x = A @ x + b_force @ force[k] - b_nl @ nl
        if not np.all(np.abs(x) < bound):
            raise UnstableModelError(
                f"closed-loop simulation of {result.candidate.name!r} diverged at sample {k} "
                f"(t = {k / signals.fs:.3g} s): the model is unstable in feedback"
            )
    return out


@dataclass(frozen=True)
class AffineReconstruction:
    """Open-loop reconstruction as an affine function of the coefficients (SPEC section 6).

    For the fixed underlying linear model of an NSI result, ``ŷ(λ) = ŷ₀ + Σ_i g_i λ_i`` where
    ``ŷ₀`` is the response to the measured forces (with the least-squares initial state) and
    ``g_i`` the response to the input ``-n_i`` through the per-unit column
    ``b_i = B[:, m+i] / λ̂_i``. At ``λ = λ̂`` it reproduces the NSI open-loop reconstruction.

    Attributes
    ----------
    measured : ndarray, shape (n_samples, l)
    baseline : ndarray, shape (n_samples, l)
        ``ŷ₀``.
    signatures : ndarray, shape (n_samples, l, q)
        ``g_i`` per unit coefficient.
    estimate : ndarray, shape (q,)
        λ̂ from NSI.
    names : tuple of str
        Term names.
    """

    measured: np.ndarray
    baseline: np.ndarray
    signatures: np.ndarray
    estimate: np.ndarray
    names: tuple[str, ...]

    @property
    def base_residual(self) -> np.ndarray:
        """``y - ŷ₀``, shape (n_samples, l)."""
        return self.measured - self.baseline

    def predict(self, coefficients) -> np.ndarray:
        """``ŷ(λ)``, shape (n_samples, l)."""
        return self.baseline + self.signatures @ np.asarray(coefficients, dtype=float)


def affine_reconstruction(result, signals: Signals) -> AffineReconstruction:
    """Affine decomposition of the open-loop reconstruction of ``result`` on ``signals``.

    Raises
    ------
    NotIdentifiableError
        When an estimated coefficient is exactly zero (the per-unit column is undefined).
    """
    from ..exceptions import NotIdentifiableError

    model = result.model
    m = len(result.input_dofs)
    estimate = result.coefficient_values
    if np.any(estimate == 0):
        raise NotIdentifiableError("a coefficient estimate is exactly zero; its per-unit signature is undefined")
    factor = getattr(result, "upsample", 1)
    u = result.extended_input(signals)
    y_work = np.asarray(result.working_signals(signals).displacement) if factor > 1 else np.asarray(signals.displacement)
    y = np.asarray(signals.displacement)
    x0 = initial_state(model, u, y_work)
    unit_b = model.B[:, m:] / estimate
    force_model = StateSpaceModel(model.A, model.B[:, :m], model.C, model.D[:, :m], model.dt)
    baseline = force_model.simulate(u[:, :m], x0)[::factor]
    term_model = StateSpaceModel(model.A, unit_b, model.C, model.D[:, m:] / estimate, model.dt)
    q = u.shape[1] - m
    signatures = np.empty(y.shape + (q,))
    for i in range(q):
        single = StateSpaceModel(model.A, unit_b[:, i : i + 1], model.C, term_model.D[:, i : i + 1], model.dt)
        signatures[:, :, i] = single.simulate(u[:, m + i : m + i + 1])[::factor]
    return AffineReconstruction(
        measured=y, baseline=baseline, signatures=signatures, estimate=estimate, names=tuple(t.name for t in result.terms)
    )
