"""The extended input of nonlinear subspace identification: forces and feedback terms (paper Eq. 8).

The nonlinear terms of a candidate enter as extra "feedback" inputs ``u = [f; -n_1(y, ẏ); ...;
-n_q(y, ẏ)]`` of a linear system, whose identification then gives the underlying linear model and
the coefficients λ_i (docs/method.md §2).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..exceptions import InputDataError, NotIdentifiableError
from ..models import CandidateModel, Term
from ..signals import Signals

__all__ = ["as_candidate", "extended_input", "resolve_input_hold", "working_signals"]


def extended_input(
    signals: Signals,
    terms: Sequence[Term],
    velocity_method: str = "fourth",
    input_hold: str = "auto",
    subsamples: int = 8,
) -> np.ndarray:
    """Build the extended input ``u = [f, -n_1, ..., -n_q]`` of a candidate (paper Eq. 8).

    Parameters
    ----------
    signals : Signals
        Measured forces and responses.
    terms : sequence of Term
        The candidate's nonlinear terms ``n_i`` (empty: the forces alone).
    velocity_method : str
        Differentiator when the signals carry no velocities (see :func:`bayesnsi.signals.differentiate`).
    input_hold : {"auto", "average", "sample"}
        How a sample of the extended input represents the interval ``[t_k, t_{k+1})`` of the
        discrete model (zero-order hold is an approximation for inputs that are not piecewise
        constant). "sample": the point value at ``t_k``. "average": the interval mean,
        ``(1/Δt)∫ u dt``, which is the zero-order-hold-equivalent input to second order in
        ``ωΔt``; forces exactly under the band-limited assumption (an anti-aliased measurement;
        FFT with gain ``e^{jωΔt/2} sinc(ωΔt/2)``), nonlinear terms by the midpoint rule on
        ``subsamples`` points with displacement interpolated by cubic Hermite polynomials (using
        the velocities as slopes) and velocity linearly. "average" suits discontinuous terms,
        "sample" smooth ones (measurements in ``docs/measurements.md``); "auto" (default) takes
        "average" when a term contains sign(), else "sample". A ``boucwen`` term (memory,
        docs/method.md §12) is integrated along the sampled displacement; its interval mean is
        the trapezoid of its point values.
    subsamples : int
        Quadrature points per interval for "average".

    Returns
    -------
    ndarray, shape (n_samples, m + q)
        The ``m`` forces, then ``-n_i`` evaluated on the data for each of the ``q`` terms.

    Raises
    ------
    NotIdentifiableError
        When a term reads a DOF whose response is not measured, or is constant on the data.
    InputDataError
        When a term evaluates to NaN/Inf on the data, or ``input_hold`` is unknown.
    """
    input_hold = resolve_input_hold(input_hold, terms)
    force = np.asarray(signals.force)
    if input_hold == "average":
        force = _band_limited_interval_mean(force)
    if not terms:
        return np.array(force)
    measured = set(signals.output_dofs)
    for term in terms:
        missing = sorted(set(term.expr.dofs) - measured)
        if missing:
            raise NotIdentifiableError(
                f"term {term.name} reads DOF(s) {missing}, which are not measured "
                f"(responses at {list(signals.output_dofs)}); add those channels to [data] outputs"
            )
    x_dofs = sorted({d for t in terms for d in t.expr.displacement_dofs})
    v_dofs = sorted({d for t in terms for d in t.expr.velocity_dofs})
    if input_hold == "average":
        v_dofs = sorted(set(v_dofs) | set(x_dofs))  # Hermite interpolation uses the slopes
    x, v = signals.state_rows(x_dofs, v_dofs, velocity_method)
    periodic = signals.period is not None and signals.period == signals.n_samples  # one period: steady state
    columns = [force]
    for term in terms:
        if term.expr.is_constant:  # an offset: the same force at every sample (exact interval mean)
            columns.append(np.full((len(force), 1), -float(term.expr.function({}, {}))))
            continue
        if term.expr.memory is not None:
            value = -_memory_input(term, x, v, periodic, input_hold == "average")
        elif input_hold == "average":
            value = -_interval_mean(term, x, v, signals.dt, subsamples)
        else:
            value = -term.evaluate(x, v)
        if not np.all(np.isfinite(value)):
            raise InputDataError(
                f"term {term.name} gives NaN/Inf on the data (e.g. division by zero); rewrite the expression"
            )
        spread = np.std(value)
        if not spread > 1e-150 * max(1.0, float(np.max(np.abs(value)))) or not np.isfinite(1.0 / spread):
            raise NotIdentifiableError(
                f"term {term.name} is constant (or numerically zero) on the data, so its coefficient is not "
                "identifiable; remove it or check the expression"
            )
        columns.append(value[:, None])
    return np.hstack(columns)


def resolve_input_hold(input_hold: str, terms: Sequence[Term]) -> str:
    """Resolve ``input_hold="auto"`` for a set of terms.

    Parameters
    ----------
    input_hold : {"auto", "average", "sample"}
        As in :func:`extended_input`.
    terms : sequence of Term
        The candidate's terms.

    Returns
    -------
    str
        "average" for "auto" when a term is discontinuous (contains sign()), "sample" for "auto"
        otherwise, else ``input_hold`` unchanged.

    Raises
    ------
    InputDataError
        When ``input_hold`` is not one of the three names.
    """
    if input_hold not in ("auto", "average", "sample"):
        raise InputDataError(f"input_hold must be 'auto', 'average' or 'sample', got {input_hold!r}")
    if input_hold == "auto":
        return "average" if any("sign(" in t.expr.canonical for t in terms) else "sample"
    return input_hold


def working_signals(signals: Signals, factor: int) -> Signals:
    """The signals on the identification grid (band-limited interpolation by ``factor``; 1: unchanged).

    Parameters
    ----------
    signals : Signals
        At the data's rate.
    factor : int
        Upsampling factor (``NSIOptions.upsample``).

    Returns
    -------
    Signals
    """
    if factor == 1:
        return signals
    from .._limits import DEFAULT_RUN_MEMORY, check_allocation
    from ..preprocess import upsample

    channels = signals.force.shape[1] + signals.displacement.shape[1] * (2 if signals.velocity is not None else 1)
    check_allocation(  # the upsampled record, its spectrum and the extended input built from it
        4 * 8 * signals.n_samples * int(factor) * channels,
        f"[nsi] upsample = {int(factor)} of {signals.n_samples} samples x {channels} channels (lower upsample)",
        default=DEFAULT_RUN_MEMORY,
    )

    return upsample(signals, factor)


def as_candidate(candidate) -> CandidateModel:
    """Normalise a candidate given as a CandidateModel, Term(s), (expr, at) pairs or None.

    Parameters
    ----------
    candidate : CandidateModel, Term, sequence of Term or (expr, at) pairs, or None
        None is the linear model.

    Returns
    -------
    CandidateModel
    """
    if candidate is None:
        return CandidateModel(name="linear", terms=())
    if isinstance(candidate, CandidateModel):
        return candidate
    if isinstance(candidate, Term):
        candidate = [candidate]
    terms = tuple(t if isinstance(t, Term) else Term(*t) for t in candidate)
    return CandidateModel(name=" + ".join(t.name for t in terms) or "linear", terms=terms)


def _band_limited_interval_mean(signal: np.ndarray) -> np.ndarray:
    """Exact interval means of a band-limited signal from its samples (FFT).

    The mean of ``e^{jωt}`` over ``[t_k, t_k + Δt]`` is ``e^{jωt_k} e^{jωΔt/2} sinc(ωΔt/2)``;
    the record is treated as periodic (edge effects span a few samples).
    """
    n = len(signal)
    spectrum = np.fft.rfft(signal, axis=0)
    half_phase = np.pi * np.arange(spectrum.shape[0]) / n  # ωΔt/2
    gain = np.exp(1j * half_phase) * np.sinc(half_phase / np.pi)
    return np.fft.irfft(spectrum * gain[:, None], n=n, axis=0)


def _memory_input(term: Term, x: dict, v: dict, periodic: bool, average: bool) -> np.ndarray:
    """A ``boucwen`` term along the record: point values, or their trapezoid over each interval.

    On a record of exactly one period (``periodic``) z is the periodic steady state and the last
    interval closes the period; otherwise the last sample keeps its point value.
    """
    value = term.evaluate(x, v, periodic)
    if not average:
        return value
    following = np.concatenate([value[1:], value[:1] if periodic else value[-1:]])
    return 0.5 * (value + following)


def _interval_mean(term: Term, x: dict, v: dict, dt: float, subsamples: int) -> np.ndarray:
    """Mean of n(x(t), v(t)) over each sampling interval (midpoint rule, Hermite interpolation)."""
    shift = {k: np.concatenate([a[1:], a[-1:]]) for k, a in x.items()}
    vshift = {k: np.concatenate([a[1:], a[-1:]]) for k, a in v.items()}
    total: np.ndarray | float = 0.0
    for s in (np.arange(subsamples) + 0.5) / subsamples:
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        xs = {k: h00 * x[k] + h10 * dt * v[k] + h01 * shift[k] + h11 * dt * vshift[k] for k in x}
        vs = {k: (1 - s) * v[k] + s * vshift[k] for k in v}
        value = term.evaluate(xs, vs)
        total = total + value
    mean = np.asarray(total, dtype=float) / subsamples
    mean[-1] = term.evaluate({k: a[-1:] for k, a in x.items()}, {k: a[-1:] for k, a in v.items()})[0]
    return mean
