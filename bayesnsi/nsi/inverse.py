"""Errors that suit free bodies: force prediction (inverse model, IDIM) and short-horizon simulation.

Open-loop simulation of a free body over a long record drifts (its rigid-body mode integrates
every error), so positioning axes are validated by the **force predicted from the measured
motion** (the inverse dynamic identification model, IDIM)::

    f̂ = M q̈ + C q̇ + K q + Σ λ_i n_i(q, q̇) + offset

with velocity and acceleration from the zero-phase low-pass filtered position (central
differences), compared with the measured force through the same filter, and each nonlinear
column ``n_i`` of the filtered motion passed through that filter once more (parallel filtering, as
in the IDIM literature: ``Fc sign(q̇)`` of the filtered velocity jumps where the filtered force
ramps; on the EMPS record this reproduces the published IDIM-LS values to four digits), and by
simulation over **short horizons** (initial state fitted on the first samples of each window). See docs/method.md §11.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import NotIdentifiableError
from ..noise import white_noise_std
from ..signals import Signals
from .feedback import extended_input, working_signals
from .reconstruct import AffineReconstruction, initial_state

__all__ = [
    "ForcePrediction",
    "force_affine",
    "force_prediction",
    "inverse_force",
    "short_horizon_nrmse",
    "filtered_kinematics",
    "force_noise_std",
    "edge_samples",
    "parallel_filter",
]

EDGE_PERIODS = 5
"""Samples left out at each end of the force view, in periods of the cutoff: ``filtfilt`` pads the
force and the motion with extensions that do not obey the same dynamics, and the end transient of
the 4th-order filter lasts about three periods (simulated carriage ending in motion: 180 N error at
the last sample, 0.5 N three periods in, 0.01 N after four)."""


@dataclass(frozen=True)
class ForcePrediction:
    """Force predicted from the measured motion against the measured force (inverse view).

    Attributes
    ----------
    measured : ndarray, shape (n_samples,)
        Measured force, low-pass filtered [force unit of the data].
    predicted : ndarray, shape (n_samples,)
    rmse : float
        RMS of ``measured - predicted`` (ends of ``trim`` samples excluded) [force unit].
    nrmse : float
        ``rmse / rms(measured)``.
    cutoff_hz : float
        Low-pass cutoff used for the kinematics and the force.
    quantity : str
        "force".
    """

    measured: np.ndarray
    predicted: np.ndarray
    rmse: float
    nrmse: float
    cutoff_hz: float
    quantity: str = "force"


def filtered_kinematics(signals: Signals, cutoff_hz: float | None = None):
    """Position, velocity, acceleration and force after a zero-phase low-pass filter.

    Parameters
    ----------
    signals : Signals
        One force and one displacement at the same DOF.
    cutoff_hz : float, optional
        Cutoff of the 4th-order Butterworth filter run forwards and backwards (default fs/20).

    Returns
    -------
    x, v, a, f : ndarray, shape (n_samples,)
    cutoff_hz : float
    """
    from scipy import signal as _signal  # when needed: 0.4 s to import
    fs = signals.fs
    cutoff = float(cutoff_hz) if cutoff_hz else fs / 20.0
    if not 0 < cutoff < fs / 2:
        raise NotIdentifiableError(f"force prediction: cutoff {cutoff:g} Hz must lie in (0, {fs / 2:g}) Hz")
    sos = _signal.butter(4, cutoff, fs=fs, output="sos")
    x = _signal.sosfiltfilt(sos, np.asarray(signals.displacement)[:, 0])
    f = _signal.sosfiltfilt(sos, np.asarray(signals.force)[:, 0])
    v = np.gradient(x, 1.0 / fs)
    a = np.gradient(v, 1.0 / fs)
    return x, v, a, f, cutoff


def parallel_filter(column, fs: float, cutoff_hz: float) -> np.ndarray:
    """A regressor column through the force view's zero-phase low-pass (parallel filtering).

    The linear columns ``a, v, x`` of the filtered position are already what the filter makes of
    the motion; a nonlinear column ``n(x, v)`` of the filtered motion is not (``sign(v)`` jumps
    where the filtered force ramps), so it is filtered once more, as the force was.

    Parameters
    ----------
    column : ndarray, shape (n_samples,)
    fs : float
        Sampling rate [Hz].
    cutoff_hz : float
        Cutoff of :func:`filtered_kinematics` [Hz].

    Returns
    -------
    ndarray, shape (n_samples,)
    """
    from scipy import signal as _signal  # when needed: 0.4 s to import
    return _signal.sosfiltfilt(_signal.butter(4, cutoff_hz, fs=fs, output="sos"), np.asarray(column, dtype=float))


def edge_samples(fs: float, cutoff_hz: float) -> int:
    """Samples left out at each end of a record filtered for the force view (:data:`EDGE_PERIODS`).

    Parameters
    ----------
    fs : float
        Sampling rate [Hz].
    cutoff_hz : float
        Low-pass cutoff [Hz].

    Returns
    -------
    int
        ``ceil(EDGE_PERIODS · fs / cutoff)``.
    """
    return int(np.ceil(EDGE_PERIODS * fs / cutoff_hz))


def force_noise_std(signals: Signals, cutoff_hz: float | None = None) -> float:
    """Std of the measured force's white noise left after the force view's low-pass filter.

    The white-noise level of the raw force from high-order differences
    (:func:`bayesnsi.nsi.white_noise_std`) times the noise gain of the zero-phase filter of
    :func:`filtered_kinematics`, ``sqrt(mean |H(e^{iω})|⁴)`` over ``[0, π]`` (0.30 at fs/20): the
    level a force residual that holds nothing but measurement noise reaches.

    Parameters
    ----------
    signals : Signals
        One force channel.
    cutoff_hz : float, optional
        Low-pass cutoff (default fs/20).

    Returns
    -------
    float
        [force unit]; 0 when the force has no detectable noise.
    """
    from scipy import signal as _signal  # when needed: 0.4 s to import
    fs = signals.fs
    cutoff = float(cutoff_hz) if cutoff_hz else fs / 20.0
    if not 0 < cutoff < fs / 2:
        raise NotIdentifiableError(f"force noise: cutoff {cutoff:g} Hz must lie in (0, {fs / 2:g}) Hz")
    _, response = _signal.sosfreqz(_signal.butter(4, cutoff, fs=fs, output="sos"), worN=4096)
    white = float(white_noise_std(np.asarray(signals.force, dtype=float)[:, :1])[0])
    return white * float(np.sqrt(np.mean(np.abs(response) ** 4)))


def inverse_force(
    mass, damping, stiffness, terms, coefficients, x, v, a, offset: float = 0.0,
    fs: float | None = None, cutoff_hz: float | None = None,
) -> np.ndarray:
    """``M a + C v + K x + Σ λ_i n_i(x, v) + offset`` for a one-DOF model.

    Parameters
    ----------
    mass, damping, stiffness : float
        M [kg], C [N s/m], K [N/m].
    terms : sequence of Term
        Nonlinear terms at the DOF (their expressions read DOF-major rows: row 0 is the DOF).
    coefficients : sequence of float
        λ_i.
    x, v, a : ndarray, shape (n_samples,)
        Position, velocity, acceleration.
    offset : float
        Constant force.
    fs, cutoff_hz : float, optional
        With both, each nonlinear column is passed through :func:`parallel_filter` (``x, v, a``
        then come from :func:`filtered_kinematics` at that cutoff).

    Returns
    -------
    ndarray, shape (n_samples,)
    """
    force = mass * a + damping * v + stiffness * x + offset
    for term, value in zip(terms, coefficients):
        dof = max(term.expr.dofs, default=1)  # a constant (offset) reads no DOF
        rows_x, rows_v = np.zeros((dof, len(x))), np.zeros((dof, len(x)))
        rows_x[:], rows_v[:] = x, v  # one DOF: every row is the measured one
        column = term.evaluate(rows_x, rows_v)
        if fs and cutoff_hz and np.ptp(column) > 0:  # a constant passes the filter unchanged
            column = parallel_filter(column, fs, cutoff_hz)
        force = force + value * column
    return force


def force_prediction(
    result, signals: Signals, cutoff_hz: float | None = None, offset: float = 0.0, trim: int | None = None
) -> ForcePrediction:
    """Force predicted by an identified one-DOF model from the measured motion (IDIM view).

    Parameters
    ----------
    result : NSIResult
        A one-DOF candidate (one force, one displacement, same DOF); its mass, damping and
        stiffness come from :attr:`NSIResult.physical_parameters`, the λ_i from NSI.
    signals : Signals
        Data to predict (estimation or validation).
    cutoff_hz : float, optional
        Low-pass cutoff (default fs/20), see :func:`filtered_kinematics`.
    offset : float
        Constant force added to the prediction, e.g. the mean force of the estimation record when
        the identification removed it (nothing is fitted on ``signals``).
    trim : int, optional
        Samples left out at each end (filter transients; default :func:`edge_samples`).

    Returns
    -------
    ForcePrediction

    Raises
    ------
    NotIdentifiableError
        When the model is not a one-DOF model (no physical parameters).
    """
    params = result.physical_parameters
    if not params:
        raise NotIdentifiableError(
            f"candidate {result.candidate.name!r}: the force prediction needs one force and one displacement "
            "at the same DOF (a one-DOF model)"
        )
    (phys,) = params
    x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
    predicted = inverse_force(
        phys.mass, phys.damping, phys.stiffness, result.terms, result.coefficient_values, x, v, a,
        fs=signals.fs, cutoff_hz=cutoff,
    )
    keep = slice(int(trim if trim is not None else edge_samples(signals.fs, cutoff)), None)
    keep = slice(keep.start, len(f) - keep.start)
    predicted = predicted + float(offset)
    err = (f - predicted)[keep]
    rmse = float(np.sqrt(np.mean(err**2)))
    return ForcePrediction(f, predicted, rmse, rmse / float(np.sqrt(np.mean(f[keep] ** 2))), cutoff)


def force_affine(
    result, signals: Signals, cutoff_hz: float | None = None, profile: bool = False
) -> AffineReconstruction:
    """The force residual of a one-DOF model as an affine function of its coefficients (IDIM view).

    ``f̂(λ) = M a + C v + K x + c + Σ_i λ_i n_i(x, v)`` on the low-pass filtered record, with M, C,
    K from :attr:`NSIResult.physical_parameters` and the constant ``c`` (the force offset, which
    the data's mean removal may have left) fitted at ``λ̂``; sampled every ``fs/cutoff``
    samples so that the filter does not multiply correlated residual samples. The evidence of a
    free body scores this residual (:func:`bayesnsi.evidence.candidate_affine`): its displacement
    residual is dominated by the drift of the rigid-body mode.

    With ``profile=True`` the linear part is not taken from NSI: the force and the basis functions
    are projected on the complement of ``[a, v, x, 1]`` (the inverse model's linear parameters
    profiled out, as in least-squares IDIM), so that the evidence of an effect does not inherit
    the error of each candidate's identified mass, damping and stiffness.

    Parameters
    ----------
    result : NSIResult
        A one-DOF candidate.
    signals : Signals
        The estimation data.
    cutoff_hz : float, optional
        Low-pass cutoff (default fs/20).
    profile : bool
        Profile the linear part out instead of taking it from NSI (see above).

    Returns
    -------
    AffineReconstruction
        ``measured`` the filtered force (its part outside ``[a, v, x, 1]`` with ``profile``),
        ``signatures`` the basis functions ``n_i`` (units of force per unit coefficient), shape
        (n, 1, q).

    Raises
    ------
    NotIdentifiableError
        When the model is not a one-DOF model.
    """
    params = result.physical_parameters
    if not params:
        raise NotIdentifiableError(
            f"candidate {result.candidate.name!r}: a force residual needs a one-DOF model (one force and one "
            "displacement at the same DOF)"
        )
    (phys,) = params
    x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
    step = max(1, int(signals.fs / cutoff))  # about one sample per correlation time of the filter
    trim = edge_samples(signals.fs, cutoff)
    keep = slice(trim, len(f) - trim, step)
    linear = inverse_force(phys.mass, phys.damping, phys.stiffness, (), (), x, v, a)
    columns = [
        inverse_force(0.0, 0.0, 0.0, (t,), (1.0,), x, v, a, fs=signals.fs, cutoff_hz=cutoff) for t in result.terms
    ]
    signatures = np.stack(columns, axis=-1)[keep] if columns else np.zeros((len(f), 0))[keep]
    estimate = np.asarray(result.coefficient_values, dtype=float)
    offset = float(np.mean((f - linear)[keep] - signatures @ estimate))
    if profile:
        q, _ = np.linalg.qr(np.column_stack([a[keep], v[keep], x[keep], np.ones_like(x[keep])]))
        measured = f[keep] - q @ (q.T @ f[keep])
        signatures = signatures - q @ (q.T @ signatures)
        return AffineReconstruction.of_result(result, measured[:, None], np.zeros((len(measured), 1)),
                                              signatures[:, None, :])
    return AffineReconstruction.of_result(result, f[keep][:, None], (linear[keep] + offset)[:, None],
                                          signatures[:, None, :])


def short_horizon_nrmse(result, signals: Signals, horizon: int, n_init: int | None = None) -> float:
    """NRMSE of the free model simulated over consecutive windows of ``horizon`` samples.

    Each window starts from a least-squares initial state on its first ``n_init`` samples
    (default a quarter of the window) and is simulated open loop with the measured forces (and
    the nonlinear inputs of the measured motion); the error is pooled over all windows. For a free
    body this replaces the long open-loop simulation that drifts.

    Parameters
    ----------
    result : NSIResult
    signals : Signals
        At the data's rate.
    horizon : int
        Window length in data samples (≥ 4).
    n_init : int, optional
        Samples per window used for the initial state.

    Returns
    -------
    float
        ``rms(y - ŷ)/rms(y)`` over all windows and channels (means of each window removed from
        ``y`` in the normalisation, so that a drifting position does not flatter the ratio).
    """
    horizon = int(horizon)
    if horizon < 4:
        raise NotIdentifiableError(f"short-horizon simulation needs a horizon of at least 4 samples, got {horizon}")
    factor = result.upsample
    work = working_signals(signals, factor)
    u = extended_input(work, result.terms, result.options.velocity_method,
                       result.options.input_hold)
    y = np.asarray(work.displacement)
    model = result.free_model
    init = max(2, int(n_init if n_init is not None else horizon // 4)) * factor
    span = horizon * factor
    errors, levels = [], []
    for start in range(0, len(u) - span + 1, span):
        uu, yy = u[start : start + span], y[start : start + span]
        forced = model.simulate(uu)
        x0 = initial_state(model, uu[:init], yy[:init], forced=forced[:init])
        predicted = model.simulate(uu, x0)
        errors.append((yy - predicted)[::factor])
        levels.append((yy - yy.mean(axis=0))[::factor])
    if not errors:
        raise NotIdentifiableError(f"the record ({len(y) // factor} samples) is shorter than the horizon {horizon}")
    err, lev = np.concatenate(errors), np.concatenate(levels)
    return float(np.sqrt(np.sum(err**2) / np.sum(lev**2)))
