"""Open- and closed-loop reconstruction of an identified candidate (SPEC section 5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import UnstableModelError
from ..signals import Signals
from .statespace import StateSpaceModel

__all__ = ["Reconstruction", "reconstruct", "nrmse", "initial_state"]


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
    u = result.extended_input(signals)
    y = np.asarray(signals.displacement)
    init = len(y) if n_init is None and not closed_loop else min(n_init or 50, len(y))
    x0 = initial_state(model, u[:init], y[:init])
    if not closed_loop:
        predicted = model.simulate(u, x0)
    else:
        predicted = _closed_loop(result, signals, x0)
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
    d_force = D[:, :m]
    out = np.empty((n_samples, n_out))
    x = np.array(x0, dtype=float)
    xs = np.full(n_dofs, np.nan)
    vs = np.full(n_dofs, np.nan)
    bound = 1e6 * max(1.0, float(np.max(np.abs(signals.displacement))))
    for k in range(n_samples):
        yk = C @ x + d_force @ force[k]
        out[k] = yk
        xs[rows] = yk
        vs[rows] = c_vel @ x
        drive = b_force @ force[k]
        for idx, term in enumerate(terms):
            drive -= b_nl[:, idx] * float(term.expr.function(xs, vs))
        x = A @ x + drive
        if not np.all(np.abs(x) < bound):
            raise UnstableModelError(
                f"closed-loop simulation of {result.candidate.name!r} diverged at sample {k} "
                f"(t = {k / signals.fs:.3g} s): the model is unstable in feedback"
            )
    return out
