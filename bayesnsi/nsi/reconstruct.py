"""Open- and closed-loop reconstruction of an identified candidate (docs/method.md §5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import UnstableModelError
from ..signals import Signals
from . import _harmonic
from ._recursion import delayed_first_order
from .closed_loop import closed_loop_response, divergence_bound
from .statespace import StateSpaceModel, decay_lengths

__all__ = [
    "Reconstruction",
    "reconstruct",
    "nrmse",
    "initial_state",
    "AffineReconstruction",
    "affine_reconstruction",
]


def nrmse(measured: np.ndarray, predicted: np.ndarray):
    """NRMSE per channel ``rms(y - ŷ)/rms(y)`` and overall (RMS over channels), docs/method.md §5.

    Parameters
    ----------
    measured : ndarray, shape (n_samples, l)
        Measured response.
    predicted : ndarray, shape (n_samples, l)
        Model response.

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

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(self, closed_loop=self.closed_loop, nrmse=self.nrmse, measured=self.measured)

    @property
    def residual(self) -> np.ndarray:
        """``y - ŷ``, shape (n_samples, l)."""
        return self.measured - self.predicted

    @property
    def rmse(self) -> np.ndarray:
        """RMS error per channel, in the output's units."""
        return np.sqrt(np.mean(self.residual**2, axis=0))


def initial_state(model: StateSpaceModel, inputs: np.ndarray | None, outputs: np.ndarray, forced=None) -> np.ndarray:
    """Least-squares initial state for a given input/output record.

    Minimises ``Σ_k ‖y_k - ŷ_k^{forced} - C A^k x₀‖²``. The normal matrix
    ``Σ_k (C A^k)ᵀ C A^k`` is summed in closed form in modal coordinates (geometric series) and
    the right-hand side ``Σ_k λ_p^k (C v_p)ᴴ r_k`` by one backward first-order recursion per
    mode (Horner), so the cost is O(N n l), not O(N n² l).

    Parameters
    ----------
    model : StateSpaceModel
    inputs : ndarray, shape (N, m), or None
        Not read when ``forced`` is given.
    outputs : ndarray, shape (N, l)
    forced : ndarray, shape (N, l), optional
        The zero-initial-state response to ``inputs`` when already computed.

    Returns
    -------
    ndarray, shape (n,)
        The initial state ``x₀``.
    """
    if forced is None:
        forced = model.simulate(inputs)
    residual = np.asarray(outputs, dtype=float) - forced
    lam, vec = np.linalg.eig(model.A)
    vinv = np.linalg.inv(vec)
    cm = model.C @ vec
    n_samples = len(residual)
    prod = lam[:, None] * lam[None, :]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        series = np.where(np.abs(1 - prod) > 1e-12, (1 - prod**n_samples) / (1 - prod), n_samples)
    normal = (vinv.T @ ((cm.T @ cm) * series) @ vinv).real
    # Σ_k λ_p^k r_k · C v_p by Horner backwards, one mode of each conjugate pair (real data)
    lam_half, vec_half, vinv_half, weight = model._modal_half()
    lengths = decay_lengths(lam_half, n_samples)  # λ^k r_k beyond: below rounding
    projected = residual[: int(np.max(lengths, initial=0))] @ (model.C @ vec_half)
    # the last output of lfilter([1], [1, -λ]) is the final state of the delayed recursion
    weighted = np.array([delayed_first_order(lp, projected[: lengths[p], p][::-1])[1][0]
                         for p, lp in enumerate(lam_half)])
    rhs = (vinv_half.T @ (weighted * weight)).real
    return np.linalg.lstsq(normal, rhs, rcond=None)[0]


def reconstruct(result, signals: Signals, closed_loop: bool = False, n_init: int | None = None) -> Reconstruction:
    """Reconstruct the measured response with an identified candidate (docs/method.md §5).

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        Data to reconstruct (estimation or validation data); several ``realisations`` each on its own.
    closed_loop : bool
        Open loop (default): the model driven by ``[f, -n_i(y_measured)]``. Closed loop: the
        nonlinear inputs evaluated on the model's own simulated displacements and velocities
        (velocity output ``C A_c x``), needed for validation data; for a frequency-route model
        on whole periods, the periodic steady state on the fitted lines (harmonic balance,
        :mod:`._harmonic`; no initial state), and on any other record (a sweep) the same on the
        record followed by as many zeros (:func:`._harmonic.record_closed_loop`).
    n_init : int, optional
        Samples used to estimate the initial state (default: all for open loop, 50 for closed
        loop, as in the Silverbox benchmark rules).

    Returns
    -------
    Reconstruction
        Measured and predicted responses, initial state and NRMSE.

    Raises
    ------
    UnstableModelError
        When the closed-loop simulation diverges (a wrong model can be unstable in feedback).
    """
    model = result.model
    if signals.realisations > 1 and not (closed_loop and _harmonic.applies(result, signals)):
        parts = [reconstruct(result, one, closed_loop, n_init) for one in signals.realisation_records()]
        predicted = np.concatenate([p.predicted for p in parts])  # each realisation from its own initial state
        per, overall = nrmse(np.asarray(signals.displacement), predicted)
        return Reconstruction(measured=np.asarray(signals.displacement), predicted=predicted, closed_loop=closed_loop,
                              x0=parts[0].x0, nrmse_per_channel=per, nrmse=overall)
    if closed_loop and _harmonic.applies(result, signals):  # periodic record, frequency route: steady state
        predicted = _harmonic.periodic_closed_loop(result, signals)
        per, overall = nrmse(np.asarray(signals.displacement), predicted)
        return Reconstruction(measured=np.asarray(signals.displacement), predicted=predicted, closed_loop=True,
                              x0=np.zeros(model.order), nrmse_per_channel=per, nrmse=overall)
    factor = result.upsample  # identified on a finer grid: work there, compare at the data's samples
    work = result.working_signals(signals)
    u = result.extended_input(work, on_grid=True)
    y_work = np.asarray(work.displacement)
    init = len(y_work) if n_init is None and not closed_loop else min((n_init or 50) * factor, len(y_work))
    if not closed_loop:  # one simulation: the forced response serves the initial state and the prediction
        forced = model.simulate(u)
        x0 = initial_state(model, u[:init], y_work[:init], forced=forced[:init])
        with np.errstate(over="ignore", invalid="ignore"):
            predicted = forced + model.initial_response(x0, len(u))
        if not np.all(np.isfinite(predicted)):
            raise UnstableModelError("simulation diverged: the model is unstable")
    elif _harmonic.applies_to_record(result, signals):  # frequency route, any other record: on the fitted lines
        predicted, x0 = _harmonic.record_closed_loop(result, signals, init // factor)
        return _reconstruction(signals, predicted, x0)
    else:
        x0 = initial_state(model, u[:init], y_work[:init])
        free = _measured_grid(result, signals) if result.virtual_stiffness else work
        predicted = _closed_loop(result, free, x0)
    y = np.asarray(signals.displacement)
    predicted = predicted[::factor]
    per, overall = nrmse(y, predicted)
    return Reconstruction(
        measured=y, predicted=predicted, closed_loop=closed_loop, x0=x0, nrmse_per_channel=per, nrmse=overall
    )


def _reconstruction(signals: Signals, predicted: np.ndarray, x0: np.ndarray) -> Reconstruction:
    """A closed-loop :class:`Reconstruction` of ``signals`` at the data's samples."""
    per, overall = nrmse(np.asarray(signals.displacement), predicted)
    return Reconstruction(measured=np.asarray(signals.displacement), predicted=predicted, closed_loop=True, x0=x0,
                          nrmse_per_channel=per, nrmse=overall)


def _measured_grid(result, signals: Signals) -> Signals:
    """The measured forces on the model's grid, without a free body's virtual spring."""
    from .feedback import working_signals

    return working_signals(signals, result.upsample)


def _closed_loop(result, signals: Signals, x0: np.ndarray) -> np.ndarray:
    """Simulate with the nonlinear inputs fed back from the model's own output (free model)."""
    bound = divergence_bound(signals.displacement)
    return closed_loop_response(result, signals.force, x0, bound, signals.n_dofs, signals.fs)[0]


@dataclass(frozen=True)
class AffineReconstruction:
    """Open-loop reconstruction as an affine function of the coefficients (docs/method.md §6).

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

    @classmethod
    def of_result(cls, result, measured, baseline, signatures) -> AffineReconstruction:
        """The affine reconstruction of an NSI result: its estimate and term names with the given arrays.

        Parameters
        ----------
        result : NSIResult
        measured, baseline : ndarray, shape (n_samples, l)
        signatures : ndarray, shape (n_samples, l, q)

        Returns
        -------
        AffineReconstruction
        """
        return cls(measured=measured, baseline=baseline, signatures=signatures,
                   estimate=np.asarray(result.coefficient_values, dtype=float),
                   names=tuple(t.name for t in result.terms))

    @property
    def base_residual(self) -> np.ndarray:
        """``y - ŷ₀``, shape (n_samples, l)."""
        return self.measured - self.baseline

    def predict(self, coefficients) -> np.ndarray:
        """Predicted response ``ŷ(λ) = baseline + signatures @ λ``.

        Parameters
        ----------
        coefficients : array_like, shape (q,)
            λ.

        Returns
        -------
        ndarray, shape (n_samples, l)
        """
        return self.baseline + self.signatures @ np.asarray(coefficients, dtype=float)


def affine_reconstruction(result, signals: Signals) -> AffineReconstruction:
    """Affine decomposition of the open-loop reconstruction of ``result`` on ``signals``.

    Parameters
    ----------
    result : NSIResult
        The identified candidate.
    signals : Signals
        Data to reconstruct (at the data's own rate).

    Returns
    -------
    AffineReconstruction
        ``ŷ(λ) = baseline + Σ_i λ_i signatures[..., i]``, exact for the identified model.

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
    if _harmonic.applies(result, signals):  # frequency route, whole periods: on the fitted lines (docs/method.md §11)
        y, baseline, signatures = _harmonic.periodic_affine(result, signals)
        return AffineReconstruction.of_result(result, y, baseline, signatures)
    factor = result.upsample
    work = result.working_signals(signals)
    u = result.extended_input(work, on_grid=True)
    y_work = np.asarray(work.displacement)
    y = np.asarray(signals.displacement)
    unit = np.concatenate([np.ones(m), estimate])  # per-unit columns for the terms
    per_unit = StateSpaceModel(model.A, model.B / unit, model.C, model.D / unit, model.dt)
    each = per_unit.simulate_each(u)  # (N_work, l, m + q): forces and unit terms, zero state
    forced_by_force = each[:, :, :m].sum(axis=2)
    forced = forced_by_force + each[:, :, m:] @ estimate
    x0 = initial_state(model, u, y_work, forced=forced)
    free = model.initial_response(x0, len(u))
    baseline = (forced_by_force + free)[::factor]
    signatures = np.ascontiguousarray(each[::factor, :, m:])
    return AffineReconstruction.of_result(result, y, baseline, signatures)
