"""Closed-loop prediction of a periodic record by harmonic balance (docs/method.md §11).

A frequency-route model was fitted on the lines of its band; on a periodic record in steady state
its closed-loop response is the periodic solution of

    X(k) = G_F(ω_k) F(k) + G_N(ω_k) U_N(k),   U_N = DFT of -n(x(t), ẋ(t)) over one period,

on those lines, with x(t) the inverse DFT of X (the other lines empty, in prediction as in the
fitted model) and ẋ its exact spectral derivative, the basis evaluated as in identification
(point values, as :func:`bayesnsi.nsi.feedback.extended_input` takes them; a term with memory in its
periodic steady state over the period, docs/method.md §12). No initial state is estimated and
nothing is integrated in time: a time simulation of the black-box model from a state fixed on a
few samples diverged within the first samples on the simulated ground vibration test for every
friction model, while this solution is what the test measured after its transient periods. The
equation is solved by a damped fixed-point iteration (the step halved when the residual grows,
grown again after successes), then by Newton-Krylov where that stalls.

:func:`periodic_affine` is the open-loop counterpart that the evidence scores: the measured
response on the same lines against the model driven by each period's force and by the basis
spectra of the period-averaged response (docs/method.md §11).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import UnstableModelError
from ..signals import Signals
from ._aft import basis_spectra
from .periodic import period_dft

__all__ = ["applies", "applies_to_record", "periodic_affine", "periodic_closed_loop", "record_closed_loop"]

_FIXED_POINT_STEPS = 60
_NEWTON_STEPS = 30
_TOLERANCE = 1e-9  # relative residual ||T(X) - X|| / ||X|| accepted as converged
_INITIAL_STATE_ROUNDS = 3  # initial state and forced solution of a record that is not periodic, in turn
_ACCEPT = 1e-3  # a discontinuous basis (sign) may cycle: a residual below this is still a steady state


def applies(result, signals: Signals) -> bool:
    """A frequency-route result and a record of whole periods: the closed loop is solved on the lines.

    Parameters
    ----------
    result : NSIResult
    signals : Signals

    Returns
    -------
    bool
    """
    period = signals.period
    return (
        result.options.domain == "frequency"
        and period is not None
        and signals.n_samples % period == 0
        and not result.virtual_stiffness
    )


def applies_to_record(result, signals: Signals) -> bool:
    """A frequency-route result and a record that is not whole periods (a sweep): :func:`record_closed_loop`.

    Parameters
    ----------
    result : NSIResult
    signals : Signals

    Returns
    -------
    bool
    """
    return (result.options.domain == "frequency" and not result.virtual_stiffness
            and not applies(result, signals) and getattr(signals, "realisations", 1) == 1)


def record_closed_loop(result, signals: Signals, n_init: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop response of a frequency-route model to a record that is not periodic (a sine sweep).

    The model holds on the lines of its band only; simulated in time, its response outside the band
    (arbitrary gains of the nonlinear-input channels near DC, amplified by the integration to
    displacement) can diverge (docs/method.md §11). Here the record, followed by as many zeros, is
    taken as one period of a periodic record and solved by harmonic balance on the lines of the
    fitted band (:func:`periodic_closed_loop`): the kinematics fed to the basis functions are
    band-limited as in identification and nothing outside the band is fed back; the zeros let the
    response to the record's end die out before it wraps onto its start. The motion the record
    starts with enters as the linear model's free response from an initial state fitted to the
    first ``n_init`` samples' difference between the measured response and the solution from rest
    (its whole band, as the time route's initial state), added to the displacement and velocity the
    basis functions see and to the prediction; the solution is then found again with it.

    Parameters
    ----------
    result : NSIResult
        Identified by the frequency route.
    signals : Signals
        Any record (one realisation).
    n_init : int
        Samples that fix the initial state (0: the record starts at rest).

    Returns
    -------
    displacement : ndarray, shape (n_samples, l)
        At the output DOFs.
    x0 : ndarray, shape (n,)
        The initial state of the stored model (zeros without ``n_init``).

    Raises
    ------
    UnstableModelError
        When no steady state is found (:func:`periodic_closed_loop`).
    """
    n = signals.n_samples
    force = np.concatenate([np.asarray(signals.force, dtype=float), np.zeros_like(signals.force)])
    shown = np.concatenate([np.asarray(signals.displacement, dtype=float), np.zeros_like(signals.displacement)])
    padded = Signals(force=force, displacement=shown, fs=signals.fs,  # the displacement is not used
                     input_dofs=result.input_dofs, output_dofs=result.output_dofs, period=2 * n)
    at_rest = periodic_closed_loop(result, padded)[:n]
    model = result.free_model
    x0 = np.zeros(model.order)
    init = min(int(n_init), n)
    if init < 1:
        return at_rest, x0
    step = max(int(round(1.0 / (signals.fs * model.dt))), 1)  # the stored model may run on a finer grid
    A_step = np.linalg.matrix_power(model.A, step)
    observed = np.empty((init, model.C.shape[0], model.order))  # C A_step^k
    observed[0] = model.C
    for k in range(1, init):
        observed[k] = observed[k - 1] @ A_step
    solution, forced = at_rest, at_rest
    measured = np.asarray(signals.displacement, dtype=float)
    c_vel = model.C @ model.continuous_state_matrix()
    for _ in range(_INITIAL_STATE_ROUNDS):  # the forced part depends on the free motion through the basis
        gap = (measured[:init] - forced[:init]).ravel()
        x0 = np.linalg.lstsq(observed.reshape(-1, model.order), gap, rcond=None)[0]
        trajectory = np.empty((n, model.order))
        x = x0
        for k in range(n):
            trajectory[k] = x
            x = A_step @ x
        free = np.zeros((2, 2 * n, len(result.output_dofs)))
        free[0, :n] = trajectory @ model.C.T
        free[1, :n] = trajectory @ c_vel.T
        solution = periodic_closed_loop(result, padded, free)[:n]
        forced = solution - free[0, :n]
        if not result.terms:
            break
    return solution, x0


def periodic_closed_loop(result, signals: Signals, free=None) -> np.ndarray:
    """Periodic steady-state closed-loop response of ``result`` to the forces of ``signals``.

    Parameters
    ----------
    result : NSIResult
        Identified by the frequency route (``fit.fit_band_hz`` are the fitted lines).
    signals : Signals
        Whole periods of a periodic record (``period`` set); with several ``realisations`` each is
        solved on its own and the results follow each other.

    Returns
    -------
    ndarray, shape (n_samples, l)
        Displacements at the output DOFs, one period repeated, nonzero only on the fitted band's lines.

    free : ndarray, shape (2, n_samples, l), optional
        Displacement and velocity added to the solution on the lines (one period), in the basis
        functions' arguments and in the result (:func:`record_closed_loop`: a free response).

    Raises
    ------
    UnstableModelError
        When no periodic solution is found (the iteration diverges or does not settle).
    """
    if getattr(signals, "realisations", 1) > 1:  # each realisation has its own steady state (new phases)
        return np.concatenate([periodic_closed_loop(result, one) for one in signals.realisation_records()])
    period = int(signals.period or 0)
    fit = result.fit.fit_band_hz or result.band_hz
    freqs = np.fft.rfftfreq(period, 1.0 / signals.fs)
    lines = np.flatnonzero((freqs >= fit[0]) & (freqs <= fit[1]) & (freqs > 0))
    force = period_dft(signals.force, period).mean(axis=0)
    G = result.frf(freqs[lines])  # (K, l, m + q) of the inputs [f; -n]
    m = force.shape[1]
    linear = np.einsum("kom,km->ko", G[:, :, :m], force[lines])
    n_out = linear.shape[1]
    omega = 2 * np.pi * freqs

    def time_of(X):
        spectrum = np.zeros((len(freqs), n_out), dtype=complex)
        spectrum[lines] = X
        x = np.fft.irfft(spectrum * period, period, axis=0)
        spectrum *= 1j * omega[:, None]
        return x, np.fft.irfft(spectrum * period, period, axis=0)

    extra = np.zeros((2, period, n_out)) if free is None else np.asarray(free, dtype=float)[:, :period]

    extra_spectra = np.fft.rfft(extra, axis=1) / period  # the free response on every line

    def inputs(X):
        spectrum = extra_spectra.copy()
        spectrum[0, lines] += X
        spectrum[1, lines] += 1j * omega[lines, None] * X
        return basis_spectra(result.terms, spectrum[0], spectrum[1], force, signals.fs, result.input_dofs,
                             result.output_dofs, period, strict=False)[lines]

    def update(X):
        return linear + np.einsum("koq,kq->ko", G[:, :, m:], inputs(X))

    X = linear
    if result.terms:
        switching = tuple(t.name for t in result.terms if t.expr.switches_with_velocity)
        start = linear
        if any(t.expr.memory is not None for t in result.terms):
            update, start = _memory_linearised(result, G[:, :, m:], linear, inputs, time_of)
        X = _solve(update, start, result.candidate.name, switching)
    x, _ = time_of(X)
    return np.tile(x + extra[0], (signals.n_samples // period, 1))


def _memory_linearised(result, G_n: np.ndarray, linear: np.ndarray, inputs, time_of, passes: int = 4):
    """The harmonic-balance map with the Bouc-Wen terms' equivalent linear part moved to the left, and its start.

    A hysteretic term ``λ z`` is stiff at small amplitude (dz/dx = 1): its feedback through the
    underlying linear model has a loop gain far above one near the linear model's resonance, which
    repels the damped fixed point. With ``-n_i ≈ -κ_i a_i(x)`` (``a_i = c_i · x`` the displacement the
    term follows, ``κ_i`` its complex equivalent stiffness per unit λ on a periodic response, least
    squares over the positive lines: its imaginary part is the loop's dissipation) the equation
    ``X = L + G_N U(X)`` is solved as ``X = (I + G_N K)⁻¹ (L + G_N (U(X) + K X))`` per line,
    ``K[i] = κ_i c_i``: the same fixed points, a contracting map when K is the equivalent stiffness
    at the solution. K is found by ``passes`` rounds of the equivalent linearisation (describing
    function): K at X, then X = (I + G_N K)⁻¹ L; that X is the start.

    Returns
    -------
    (callable, ndarray)
        The map and its start.
    """
    rows = np.array(result.output_dofs) - 1
    n_dofs = int(max(max(rows) + 1, max(max(t.dofs) for t in result.terms)))
    n_out = len(rows)
    unit = np.zeros((n_dofs, n_out))
    unit[rows, np.arange(n_out)] = 1.0
    directions = [None if t.expr.memory_argument is None else np.asarray(t.expr.memory_argument(unit, unit), float)
                  for t in result.terms]

    def equivalent(X):
        x = time_of(X)[0]
        states = np.zeros((n_dofs, len(x)))
        states[rows] = x.T
        positive = slice(1, len(x) // 2)
        gain = np.zeros((len(result.terms), n_out), dtype=complex)
        for i, (term, direction) in enumerate(zip(result.terms, directions)):
            if direction is None:
                continue
            along = np.fft.rfft(np.asarray(term.expr.memory_argument(states, states), dtype=float))[positive]
            z = np.fft.rfft(term.evaluate(states, states, periodic=True))[positive]
            power = float(np.real(np.vdot(along, along)))
            gain[i] = (np.vdot(along, z) / power if power > 0 else 0.0) * direction
        return gain, np.eye(n_out)[None] + np.einsum("koq,qj->koj", G_n, gain)

    X = linear
    for _ in range(passes):
        gain, system = equivalent(X)
        X = np.linalg.solve(system, linear[..., None])[..., 0]

    def update(X):
        right = linear + np.einsum("koq,kq->ko", G_n, inputs(X) + X @ gain.T)
        return np.linalg.solve(system, right[..., None])[..., 0]

    return update, X


def _solve(update, start: np.ndarray, name: str, switching: tuple[str, ...] = ()) -> np.ndarray:
    """``X = update(X)``: damped fixed point, then Newton-Krylov from its best point when it stalls (a
    linearised loop gain with real part above one, e.g. a strong hardening, repels every damped step).

    ``switching`` names the model's terms whose force jumps at velocity reversals (``sign(v)``): the
    message of a failure then names them as the likely cause, which is not an instability (on the
    hysteretic record ``tanh(v1/0.01)`` with λ = -14.9 N settled where ``sign(v1)`` with -14.4 N did not).
    """
    X, step = start, 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        mapped = update(X)
        residual = float(np.linalg.norm(mapped - X))
    for _ in range(_FIXED_POINT_STEPS):
        if residual <= _TOLERANCE * _size(X):
            return X
        trial = X + step * (mapped - X)
        with np.errstate(over="ignore", invalid="ignore"):
            trial_mapped = update(trial)
            trial_residual = float(np.linalg.norm(trial_mapped - trial))
        if np.isfinite(trial_residual) and trial_residual < residual:
            X, mapped, residual = trial, trial_mapped, trial_residual
            step = min(1.0, 1.5 * step)
        else:
            step *= 0.5
            if step < 1e-4:
                break
    if residual > _TOLERANCE * _size(X):
        X, residual = _newton(update, X, residual)
    if residual <= _ACCEPT * _size(X):
        return X
    cause = (
        f"its term(s) {', '.join(switching)} switch with the velocity, and a force that jumps at each reversal has "
        "no periodic solution on a finite set of lines - on the frequency route use the smooth friction "
        "tanh(v/eps) instead (docs/method.md §7), or the model is unstable in feedback"
        if switching else "the model is unstable in feedback"
    )
    raise UnstableModelError(
        f"closed loop of {name!r}: no periodic steady state on the fitted lines (harmonic balance residual "
        f"{residual / _size(X):.2g} of the response): {cause}"
    )


def _size(X: np.ndarray) -> float:
    return max(float(np.linalg.norm(X)), 1e-300)


def _newton(update, X: np.ndarray, residual: float):
    """Newton-Krylov on the real and imaginary parts; the better of its result and ``X``."""
    shape = X.shape

    def unpack(z):
        return (z[: z.size // 2] + 1j * z[z.size // 2 :]).reshape(shape)

    def function(z):
        Z = unpack(z)
        with np.errstate(over="ignore", invalid="ignore"):
            d = update(Z) - Z
        return np.concatenate([d.real.ravel(), d.imag.ravel()])

    import scipy.optimize  # here: 0.2 s, and the module is on every command's import path

    try:  # a diverging model overflows inside the solver's own norms: it is judged by the residual below
        with np.errstate(over="ignore", invalid="ignore"):
            z = scipy.optimize.newton_krylov(function, np.concatenate([X.real.ravel(), X.imag.ravel()]),
                                             f_tol=_TOLERANCE * np.linalg.norm(X) / np.sqrt(2 * X.size),
                                             maxiter=_NEWTON_STEPS, method="lgmres")
    except (scipy.optimize.NoConvergence, ValueError, np.linalg.LinAlgError) as err:
        z = err.args[0] if isinstance(err, scipy.optimize.NoConvergence) and err.args else None
    if z is None:
        return X, residual
    with np.errstate(over="ignore", invalid="ignore"):
        found = float(np.linalg.norm(function(z)))
    return (unpack(z), found) if np.isfinite(found) and found < residual else (X, residual)


def periodic_affine(result, signals: Signals) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Open-loop reconstruction of a frequency-route ``result`` on the lines it was fitted on.

    The model holds only on the fitted lines of its band (docs/method.md §11); a time simulation of
    its nonlinear-input channels driven by the broadband basis spectra (all lines, out-of-band gain
    arbitrary) is an error the data never informed. Here, period by period: the measured response
    on the fitted lines, the linear response ``G_F(ω_k) F_p(k)`` to each period's force, and per unit
    coefficient ``G_N(ω_k) / λ̂ · U_N(k)``, ``U_N`` the DFT of ``-n`` evaluated, as in identification,
    on the period-averaged displacement and its exact spectral derivative.

    Parameters
    ----------
    result : NSIResult
        Identified by the frequency route (:func:`applies`).
    signals : Signals
        Whole periods of a periodic record (several ``realisations``: each on its own, in order).

    Returns
    -------
    measured, baseline : ndarray, shape (n_samples, l)
        Measured response and the response to the forces, both on the fitted lines only.
    signatures : ndarray, shape (n_samples, l, q)
        Response to ``-n_i`` per unit coefficient, on the fitted lines only.
    """
    if getattr(signals, "realisations", 1) > 1:  # each realisation: its own period-averaged basis spectra
        parts = [periodic_affine(result, one) for one in signals.realisation_records()]
        return tuple(np.concatenate(arrays) for arrays in zip(*parts))  # type: ignore[return-value]
    period = int(signals.period or 0)
    fit = result.fit.fit_band_hz or result.band_hz
    freqs = np.fft.rfftfreq(period, 1.0 / signals.fs)
    lines = np.flatnonzero((freqs >= fit[0]) & (freqs <= fit[1]) & (freqs > 0))
    force = period_dft(signals.force, period)  # (p, k, m)
    response = period_dft(signals.displacement, period)
    m, n_periods = force.shape[2], force.shape[0]
    G = result.frf(freqs[lines])

    def time_of(spectra):  # (p, K, ...) on the lines -> (p * P, ...)
        full = np.zeros((spectra.shape[0], len(freqs)) + spectra.shape[2:], dtype=complex)
        full[:, lines] = spectra
        return np.fft.irfft(full * period, period, axis=1).reshape((-1,) + spectra.shape[2:])

    measured = time_of(response[:, lines])
    baseline = time_of(np.einsum("kom,pkm->pko", G[:, :, :m], force[:, lines]))
    if not result.terms:
        return measured, baseline, np.zeros(measured.shape + (0,))
    x_mean = response.mean(axis=0)
    v_spec = 1j * 2 * np.pi * freqs[:, None] * x_mean
    if period % 2 == 0:
        v_spec[-1] = 0.0
    u_n = basis_spectra(result.terms, x_mean, v_spec, force.mean(axis=0), signals.fs, result.input_dofs,
                        result.output_dofs, period)[lines]
    per_unit = G[:, :, m:] / result.coefficient_values[None, None, :] * u_n[:, None, :]  # (K, l, q)
    signatures = time_of(np.broadcast_to(per_unit, (n_periods,) + per_unit.shape))
    return measured, baseline, signatures
