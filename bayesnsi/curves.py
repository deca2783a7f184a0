"""Curves that figures draw, computed by the library (the plots compute nothing).

:func:`effect_curve` evaluates the force λ·n(x, v) of one identified nonlinear term on the
measured signals, against the displacement and velocity at its location (relative ones for a
term acting between two DOFs), thinned to a number of points a scatter plot can show.
:func:`measured_frf` estimates the FRF of the data without a model (multiple-input H1), the
curve an identified model is held against over the whole excited band. :func:`hysteresis_loop` gives
the restoring force of a Bouc-Wen term against the displacement it follows: its path over a few
cycles of the record and its steady loop at the measured amplitude, with the physical reading.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .exceptions import InputDataError
from .models.hysteresis import HysteresisReading, boucwen_periodic, hysteresis_reading

__all__ = ["EffectCurve", "HysteresisLoop", "MeasuredFRF", "effect_curve", "hysteresis_loop", "measured_frf"]


@dataclass(frozen=True, eq=False)
class EffectCurve:
    """The force of one term against the state at its location.

    Attributes
    ----------
    displacement, velocity : ndarray, shape (n_points,)
        Displacement [m] and velocity [m/s] at the term's DOF, or DOF j minus DOF k for a term
        at the pair (j, k).
    force : ndarray, shape (n_points,)
        λ·n(x, v) [N] at the same instants.
    displacement_label, velocity_label : str
        Axis labels (``"x3"``, ``"v3"`` or ``"relative displacement"``, ...).
    title : str
        Term and coefficient, e.g. ``"sign(v2) @2: λ = 1.02"``.
    """

    displacement: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    displacement_label: str
    velocity_label: str
    title: str


def effect_curve(step, signals, max_points: int = 4000) -> EffectCurve:
    """Force λ·n(x, v) of a term on measured signals, against x and v at its location.

    Parameters
    ----------
    step : object with ``term`` (:class:`~bayesnsi.models.Term`) and ``coefficient`` (float)
        E.g. an accepted step of :func:`bayesnsi.loop.close_the_loop`.
    signals : Signals
        Measured signals; the term's location DOFs must be measured outputs.
    max_points : int
        At most this many instants, evenly spread over the record.

    Returns
    -------
    EffectCurve

    Raises
    ------
    InputDataError
        If ``max_points`` is below 1 or a DOF the term acts at or reads is not a measured output.
    """
    if int(max_points) != max_points or max_points < 1:
        raise InputDataError(f"max_points must be a positive integer, got {max_points!r}")
    term = step.term
    outputs = list(signals.output_dofs)
    read = (*term.at, *term.expr.displacement_dofs, *term.expr.velocity_dofs)
    missing = [d for d in read if d not in outputs]
    if missing:
        raise InputDataError(f"term {term.name} needs DOF {missing[0]}, which is not a measured output {outputs}")
    x, v = signals.state_rows(term.expr.displacement_dofs, term.expr.velocity_dofs)
    force = step.coefficient * term.evaluate(x, v)
    velocities = signals.velocities()
    j = outputs.index(term.at[0])
    xs, vs = signals.displacement[:, j], velocities[:, j]
    if len(term.at) == 2:
        k = outputs.index(term.at[1])
        xs, vs = xs - signals.displacement[:, k], vs - velocities[:, k]
        labels = ("relative displacement", "relative velocity")
    else:
        labels = (f"x{term.at[0]}", f"v{term.at[0]}")
    pick = np.linspace(0, len(force) - 1, min(int(max_points), len(force))).astype(int)
    return EffectCurve(
        displacement=xs[pick],
        velocity=vs[pick],
        force=np.asarray(force)[pick],
        displacement_label=labels[0],
        velocity_label=labels[1],
        title=f"{term.name}: λ = {step.coefficient:.4g}",
    )


@dataclass(frozen=True, eq=False)
class HysteresisLoop:
    """The force λ z of a Bouc-Wen term against the displacement it follows (docs/method.md §12).

    Attributes
    ----------
    displacement, force : ndarray, shape (n_window,)
        The measured displacement (relative for an element) over a window of the record holding
        about ``cycles`` periods of its dominant frequency, and λ z along the whole record's path there.
    loop_displacement, loop_force : ndarray, shape (n_loop,)
        One period of a sine at the reading's amplitude and λ z on it in periodic steady state (closed).
    reading : HysteresisReading
        Hysteretic stiffness, yield, loop area per cycle at that amplitude.
    displacement_label, title : str
    """

    displacement: np.ndarray
    force: np.ndarray
    loop_displacement: np.ndarray
    loop_force: np.ndarray
    reading: HysteresisReading
    displacement_label: str
    title: str


def hysteresis_loop(step, signals, cycles: float = 4.0, points: int = 512) -> HysteresisLoop:
    """The restoring-force loop of a Bouc-Wen term on measured signals (docs/method.md §12).

    Parameters
    ----------
    step : object with ``term`` (a ``boucwen`` :class:`~bayesnsi.models.Term`) and ``coefficient`` or ``value``
        E.g. an accepted step of :func:`bayesnsi.loop.close_the_loop`, or a coefficient of an
        identified model (``result.coefficients[i]``).
    signals : Signals
        Measured signals holding the displacement(s) the term follows.
    cycles : float
        Periods of the displacement's dominant frequency in the window of the measured path.
    points : int
        Samples of the steady loop.

    Returns
    -------
    HysteresisLoop

    Raises
    ------
    InputDataError
        For a term without memory or one that reads a DOF that is not a measured output.
    """
    term = step.term
    lam = float(np.real(step.coefficient if hasattr(step, "coefficient") else step.value))
    shape, argument = term.expr.memory, term.expr.memory_argument
    if shape is None or argument is None:
        raise InputDataError(f"term {term.name} is not a Bouc-Wen term (boucwen(x, beta=..., gamma=...))")
    missing = [d for d in term.expr.displacement_dofs if d not in signals.output_dofs]
    if missing:
        raise InputDataError(f"term {term.name} needs DOF {missing[0]}, which is not a measured output")
    x, v = signals.state_rows(list(term.expr.displacement_dofs), [])
    along = np.asarray(argument(x, v), dtype=float)
    force = lam * np.asarray(term.evaluate(x, v))
    reading = hysteresis_reading(shape, lam, along)
    spectrum = np.abs(np.fft.rfft(along - along.mean()))
    spectrum[0] = 0.0
    dominant = max(int(np.argmax(spectrum)), 1) * float(signals.fs) / len(along)  # [Hz]
    width = int(min(len(along), max(16, round(cycles * float(signals.fs) / dominant))))
    start = (len(along) - width) // 2
    sine = reading.amplitude * np.sin(2 * np.pi * np.arange(points + 1) / points)
    z = boucwen_periodic(shape, sine[:-1])
    dofs = term.expr.displacement_dofs
    label = f"x{dofs[0]}" if len(dofs) == 1 else f"relative displacement ({_text(term)})"
    return HysteresisLoop(
        displacement=along[start : start + width], force=force[start : start + width],
        loop_displacement=sine, loop_force=lam * np.append(z, z[:1]), reading=reading, displacement_label=label,
        title=f"{term.name}: λ = {lam:.4g}",
    )


def _text(term) -> str:
    canonical = term.expr.canonical
    return canonical[canonical.index("(") + 1 : canonical.index(",")]


@dataclass(frozen=True, eq=False)
class MeasuredFRF:
    """A nonparametric FRF of the measured data: multiple-input H1 on Welch-averaged spectra.

    Attributes
    ----------
    freqs_hz : ndarray, shape (n_lines,)
        Frequency lines [Hz] the force drives, from the first above 0 to the excited band's upper edge.
    frf : ndarray of complex, shape (n_lines, l, m)
        ``H = S_yf S_ff⁻¹`` per line: displacement per unit force, every output/force pair.
    coherence : ndarray, shape (n_lines, l)
        Multiple coherence of each output with all forces (1: the forces explain the output
        linearly; lower: noise, a nonlinearity or an unmeasured input).
    excited_hz : float
        Upper edge of the excited band: the frequency below which 99 % of the force power of the
        whole record lies.
    """

    freqs_hz: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    excited_hz: float


def measured_frf(signals, n_segment: int | None = None) -> MeasuredFRF:
    """H1 estimate of the displacement-per-force FRF from the data (Welch, multiple inputs).

    The curve a modal analyst compares a model with: where the identified model lacks a mode
    the measured FRF shows a peak the model does not. On a nonlinear structure it is the linear
    approximation at the level of the test, not the underlying linear FRF.

    Parameters
    ----------
    signals : Signals
        Forces and displacements (each realisation of a periodic test is taken as it comes).
    n_segment : int, optional
        Welch segment length [samples]; default: the period of a periodic record with a
        rectangular window (exact lines of a steady state), else the longest power of two giving
        at least 7 Hann-windowed segments with half overlap (at most 16384 samples): lines fine
        enough for lightly damped modes, at the price of a noisier curve on short records.

    Returns
    -------
    MeasuredFRF

    Raises
    ------
    InputDataError
        For a record shorter than 64 samples or a segment longer than the record.
    """
    f = np.asarray(signals.force, dtype=float).reshape(signals.n_samples, -1)
    y = np.asarray(signals.displacement, dtype=float).reshape(signals.n_samples, -1)
    n = len(f)
    if n < 64:
        raise InputDataError(f"a measured FRF needs at least 64 samples, got {n}")
    period = getattr(signals, "period", None)
    if n_segment is None:
        if period and n // int(period) >= 2:
            n_segment, window = int(period), np.ones(int(period))
        else:
            n_segment = int(min(16384, 2 ** np.floor(np.log2(max(n // 4, 32)))))
            window = np.hanning(n_segment)
    else:
        n_segment = int(n_segment)
        window = np.hanning(n_segment)
    if not 8 <= n_segment <= n:
        raise InputDataError(f"the segment of {n_segment} samples must be between 8 and the record's {n} samples")
    step = n_segment if np.all(window == 1.0) else n_segment // 2
    starts = list(range(0, n - n_segment + 1, step))
    if starts[-1] != n - n_segment and step != n_segment:  # the record's end too (a sweep's top lies there)
        starts.append(n - n_segment)
    lines = n_segment // 2 + 1
    sff = np.zeros((lines, f.shape[1], f.shape[1]), dtype=complex)
    syf = np.zeros((lines, y.shape[1], f.shape[1]), dtype=complex)
    syy = np.zeros((lines, y.shape[1]))
    for s in starts:
        F = np.fft.rfft(window[:, None] * (f[s : s + n_segment] - f[s : s + n_segment].mean(axis=0)), axis=0)
        Y = np.fft.rfft(window[:, None] * (y[s : s + n_segment] - y[s : s + n_segment].mean(axis=0)), axis=0)
        sff += F[:, :, None] * np.conj(F[:, None, :])
        syf += Y[:, :, None] * np.conj(F[:, None, :])
        syy += np.abs(Y) ** 2
    freqs = np.fft.rfftfreq(n_segment, 1.0 / float(signals.fs))
    power = np.real(np.trace(sff, axis1=1, axis2=2))
    whole = np.sum(np.abs(np.fft.rfft(f - f.mean(axis=0), axis=0)) ** 2, axis=1)  # every sample, not the segments
    cumulative = np.cumsum(whole) / max(float(whole.sum()), np.finfo(float).tiny)
    excited = float(np.fft.rfftfreq(n, 1.0 / float(signals.fs))[min(int(np.searchsorted(cumulative, 0.99)), n // 2)])
    # lines the force drives (a multisine leaves lines unexcited, where H1 is noise over nothing)
    keep = (freqs > 0) & (freqs <= excited) & (power > 1e-8 * power.max())
    sff, syf, syy, freqs = sff[keep], syf[keep], syy[keep], freqs[keep]
    ridge = 1e-12 * np.real(np.trace(sff, axis1=1, axis2=2))[:, None, None] * np.eye(sff.shape[1])
    frf = np.swapaxes(np.linalg.solve(np.swapaxes(sff + ridge, 1, 2), np.swapaxes(syf, 1, 2)), 1, 2)
    explained = np.real(np.einsum("kom,kom->ko", frf, np.conj(syf)))
    coherence = np.clip(explained / np.where(syy > 0, syy, np.inf), 0.0, 1.0)
    return MeasuredFRF(freqs_hz=freqs, frf=frf, coherence=coherence, excited_hz=excited)
