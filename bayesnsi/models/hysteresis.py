"""The Bouc-Wen hysteretic variable: a basis function with memory (docs/method.md §12).

For fixed shape parameters β, γ, n the hysteretic variable ``z`` of

    ż = ẋ - β |ẋ| |z|^(n-1) z - γ ẋ |z|^n,        z = 0 at the record's first sample,

is a function of the displacement history of ``x`` alone (the law is rate independent: divided
by ẋ it reads ``dz/dx = 1 - β sgn(ẋ) |z|^(n-1) z - γ |z|^n``), so ``λ z`` is one more term of the
extended input, with ``λ`` the hysteretic stiffness [N/m] and ``z`` in the unit of ``x``.

Integration rule. Between two samples the displacement path is taken as the straight line
through them (monotone, travel ``ξ = |x_k - x_(k-1)|``). With ``w = sgn(Δx) z`` the law becomes the
autonomous ``dw/dξ = 1 - β |w|^(n-1) w - γ |w|^n``. For ``n = 1`` it is linear on each side of
``w = 0`` (loading ``w >= 0``: ``dw/dξ = 1 - (β + γ) w``; unloading ``w < 0``: ``1 - (β - γ) w``)
and is solved exactly, the crossing of ``w = 0`` included; for other ``n`` by RK4 in ``ξ`` with at
least 4 substeps of at most 0.05 of the local time constant (within 3e-7 of a fine reference). The
only error is then that of the path between samples, which misses the travel of a reversal inside a
sampling interval (second order in ``ωΔt``; measured against a fine-step reference in
``tests/models/test_hysteresis.py``).

Evaluation by runs (n = 1). The exact steps compose: along a monotone run of the displacement
(from one reversal to the next; samples at rest continue the run) z is the exact solution over the
travel ``|x_k - x_start|`` since the run began. The path is therefore a scalar recursion over the
runs' end points followed by one vectorised evaluation at every sample: the same z as stepping
sample by sample, up to rounding (``tests/models/test_hysteresis.py``), at one scalar step per
reversal instead of per sample. Other n step sample by sample.

On a record of exactly one period (a period-averaged record of the frequency route, the period of
harmonic balance) ``z`` is the periodic steady state: the recursion runs over the period again
from its last value until the period's first value repeats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import ExpressionError, NotIdentifiableError

__all__ = [
    "BoucWen",
    "HysteresisReading",
    "boucwen_path",
    "boucwen_periodic",
    "boucwen_step",
    "hysteresis_reading",
]

MAX_N = 16.0
"""Largest exponent n of the Bouc-Wen law."""
_PERIODIC_TOLERANCE = 1e-10  # relative change of z over one more pass that counts as repeating
_PERIODIC_PASSES = 200
_RK4_FRACTION = 0.05  # largest substep over the local time constant 1 / |dg/dw| (general n)
_MIN_SUBSTEPS = 4  # the crossing of z = 0, where |z|^n is not smooth, falls inside a substep
_MAX_SUBSTEPS = 4096


@dataclass(frozen=True)
class BoucWen:
    """Shape of a Bouc-Wen hysteretic variable (module notes).

    Parameters
    ----------
    beta, gamma : float
        β, γ [1/m^n for z in m]: ``β`` sets the dissipation (β > 0 dissipates), ``β + γ`` the
        loading branch (``β + γ > 0``: z yields at ``(β + γ)^(-1/n)``; ``< 0``: it hardens),
        ``β - γ`` the unloading branch.
    n : float
        Exponent (sharpness of the yield), ``0 < n <= 16``; 1 by default.
    """

    beta: float
    gamma: float
    n: float = 1.0

    def __post_init__(self) -> None:
        values = (self.beta, self.gamma, self.n)
        if not all(isinstance(v, (int, float, np.floating, np.integer)) and np.isfinite(v) for v in values):
            raise ExpressionError(f"Bouc-Wen beta, gamma and n must be finite numbers, got {values}")
        if not 0 < self.n <= MAX_N:
            raise ExpressionError(f"Bouc-Wen n must lie in (0, {MAX_N:g}], got {self.n:g}")
        for name in ("beta", "gamma", "n"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @classmethod
    def from_branches(cls, loading: float, unloading: float, n: float = 1.0) -> BoucWen:
        """The shape with ``β + γ = loading`` and ``β - γ = unloading`` (module notes: the two branches).

        Parameters
        ----------
        loading, unloading : float
            The rates of the loading (``dz/dx = 1 - (β + γ) z``) and unloading branches (n = 1).
        n : float

        Returns
        -------
        BoucWen
        """
        return cls(0.5 * (loading + unloading), 0.5 * (loading - unloading), n)

    @property
    def loading(self) -> float:
        """``β + γ``: the loading branch levels off (> 0) or hardens (< 0)."""
        return self.beta + self.gamma

    @property
    def unloading(self) -> float:
        """``β - γ``: the stiffening of the unloading branch."""
        return self.beta - self.gamma

    @property
    def yield_displacement(self) -> float | None:
        """``(β + γ)^(-1/n)``: the value z tends to on a long loading branch; None when ``β + γ <= 0`` (no yield)."""
        total = self.beta + self.gamma
        return total ** (-1.0 / self.n) if total > 0 else None

    def text(self) -> str:
        """The parameters as written in a term: ``"beta=800,gamma=-1100"`` (``",n=2"`` when n ≠ 1)."""
        extra = "" if self.n == 1.0 else f",n={self.n:g}"
        return f"beta={self.beta:g},gamma={self.gamma:g}{extra}"


def _linear(w: float, xi: float, a: float) -> float:
    """``w`` after a travel ``xi`` of ``dw/dξ = 1 - a w`` (exact)."""
    t = a * xi
    if t == 0.0:
        return w + xi
    try:
        e = math.exp(-t)
    except OverflowError:  # a hardening branch (a < 0) over a long travel: w - 1/a grows without bound
        return 1.0 / a if w == 1.0 / a else math.copysign(math.inf, w - 1.0 / a)
    return w * e - math.expm1(-t) / a


def _slope(w, beta: float, gamma: float, n: float):
    a = np.abs(w) ** n
    return 1.0 - beta * np.sign(w) * a - gamma * a


def _substeps(w, xi, beta: float, gamma: float, n: float) -> int:
    """RK4 substeps for a travel ``xi`` from ``w`` (general n; module notes)."""
    reach = np.max(np.abs(w) + np.abs(xi))
    rate = n * (abs(beta) + abs(gamma)) * (reach ** (n - 1.0) if reach > 0 else (1.0 if n <= 1 else 0.0))
    span = float(np.max(np.abs(xi))) * rate
    if not np.isfinite(span):
        return _MAX_SUBSTEPS
    return int(min(_MAX_SUBSTEPS, max(_MIN_SUBSTEPS, math.ceil(span / _RK4_FRACTION))))


def _advance_general(w, xi, beta: float, gamma: float, n: float):
    """General n: RK4 in ξ of ``dw/dξ = 1 - β |w|^(n-1) w - γ |w|^n`` (module notes)."""
    steps = _substeps(w, xi, beta, gamma, n)
    h = xi / steps
    for _ in range(steps):
        k1 = _slope(w, beta, gamma, n)
        k2 = _slope(w + 0.5 * h * k1, beta, gamma, n)
        k3 = _slope(w + 0.5 * h * k2, beta, gamma, n)
        k4 = _slope(w + h * k3, beta, gamma, n)
        w = w + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return w


def boucwen_step(shape: BoucWen, z, dx):
    """The hysteretic variable after a displacement increment (module notes: the integration rule).

    Parameters
    ----------
    shape : BoucWen
    z : array_like
        The variable before the increment.
    dx : array_like
        The increment ``x_k - x_(k-1)`` (broadcast against ``z``), traversed monotonically.

    Returns
    -------
    ndarray
        ``z`` after the increment.
    """
    z, dx = np.broadcast_arrays(np.asarray(z, dtype=float), np.asarray(dx, dtype=float))
    s = np.where(dx < 0, -1.0, 1.0)
    w, xi = s * z, np.abs(dx)
    if shape.n != 1.0:
        return s * _advance_general(w, xi, shape.beta, shape.gamma, shape.n)
    loading, unloading = shape.beta + shape.gamma, shape.beta - shape.gamma
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        reach = 1.0 - unloading * w
        crossing = (w < 0) & (reach > 0)
        travel_to_zero = -w if unloading == 0.0 else np.log(np.where(crossing, reach, 1.0)) / unloading
        to_zero = np.where(crossing, travel_to_zero, 0.0)
        crosses = crossing & (xi > to_zero)
        start = np.where(crosses, 0.0, w)
        travel = np.where(crosses, xi - to_zero, xi)
        a = np.where((start < 0), unloading, loading)
        t = a * travel
        safe = np.where(a == 0.0, 1.0, a)
        out = np.where(t == 0.0, start + travel, start * np.exp(-t) - np.expm1(-t) / safe)
    return s * out


def _flow(w: float, xi: float, loading: float, unloading: float) -> float:
    """``w`` after a travel ``xi >= 0`` of ``dw/dξ = 1 - a w``, ``a`` the unloading rate below 0 (exact, n = 1)."""
    a = loading
    if w < 0.0:
        reach = 1.0 - unloading * w
        to_zero = (-w if unloading == 0.0 else math.log(reach) / unloading) if reach > 0.0 else math.inf
        if xi <= to_zero:
            a = unloading
        else:
            xi -= to_zero
            w = 0.0
    t = a * xi
    if t == 0.0:
        return w + xi
    if t > -700.0:
        return w * math.exp(-t) - math.expm1(-t) / a
    return _linear(w, xi, a)


def _path_by_sample(shape: BoucWen, x: np.ndarray, z0: float) -> np.ndarray:
    """z along one displacement series, one increment after the other (general n; the reference for n = 1)."""
    out = np.empty(len(x))
    if not len(x):
        return out
    z = float(z0)
    out[0] = z
    loading, unloading = shape.loading, shape.unloading
    for k, dx in enumerate(np.diff(x).tolist(), start=1):
        if dx != 0.0:
            s = 1.0 if dx > 0 else -1.0
            if shape.n == 1.0:
                z = s * _flow(s * z, abs(dx), loading, unloading)
            else:
                z = s * float(_advance_general(np.float64(s * z), abs(dx), shape.beta, shape.gamma, shape.n))
        out[k] = z
    return out


def _runs(x: np.ndarray) -> np.ndarray:
    """First sample of each monotone run of ``x`` (a reversal, or the first move, starts one; rests do not)."""
    moving = np.flatnonzero(np.diff(x))
    if not len(moving):
        return moving
    rising = np.diff(x)[moving] > 0
    return moving[np.r_[True, rising[1:] != rising[:-1]]]


def _run_starts(shape: BoucWen, x: np.ndarray, starts: np.ndarray, z0: float) -> np.ndarray:
    """z at the first sample of each run and at the last sample of the record (module notes: n = 1 exact per run)."""
    ends = x[np.r_[starts, len(x) - 1]].tolist()
    loading, unloading = shape.loading, shape.unloading
    out = [float(z0)]
    z = out[0]
    for a, b in zip(ends[:-1], ends[1:]):
        s, xi = (1.0, b - a) if b > a else (-1.0, a - b)
        z = s * _flow(s * z, xi, loading, unloading)
        out.append(z)
    return np.array(out)


def _fill(shape: BoucWen, x: np.ndarray, starts: np.ndarray, at_starts: np.ndarray) -> np.ndarray:
    """z at every sample from its value at the start of its run: the exact flow over the travel since then (n = 1)."""
    out = np.full(len(x), at_starts[0])
    if not len(starts):
        return out
    loading, unloading = shape.loading, shape.unloading
    first = starts[0] + 1
    run = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, len(x) - 1]))  # of samples first, first + 1, ...
    sign = np.where(x[np.r_[starts[1:], len(x) - 1]] > x[starts], 1.0, -1.0)
    w0 = sign * at_starts[:-1]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # per run: the travel to w = 0 from below
        reach = 1.0 - unloading * w0
        below = w0 < 0
        to_zero = np.where(below, np.where(reach > 0, (-w0 if unloading == 0.0 else np.log(reach) / unloading),
                                           np.inf), -1.0)
        after = np.where(below, 0.0, w0)
        xi = sign[run] * (x[first:] - x[starts][run])
        crossed = xi > to_zero[run]
        start = np.where(crossed, after[run], w0[run])
        travel = np.where(crossed, xi - np.where(below, to_zero, 0.0)[run], xi)
        rate = np.where(crossed, loading, unloading)
        t = rate * travel
        w = start * np.exp(-t) - np.expm1(-t) / np.where(rate == 0.0, 1.0, rate)
        if loading == 0.0 or unloading == 0.0:
            w = np.where(rate == 0.0, start + travel, w)
    out[first:] = sign[run] * w
    return out


def _path_1d(shape: BoucWen, x: np.ndarray, z0: float) -> np.ndarray:
    """z along one displacement series (n = 1: run by run, module notes; otherwise sample by sample)."""
    if shape.n != 1.0 or not len(x):
        return _path_by_sample(shape, x, z0)
    starts = _runs(x)
    at_starts = _run_starts(shape, x, starts, z0)
    path = _fill(shape, x, starts, at_starts) if np.all(np.isfinite(at_starts)) else None
    if path is None or not np.all(np.isfinite(path)):  # a hardening branch that overflows: sample by sample
        return _path_by_sample(shape, x, z0)
    return path


def boucwen_path(shape: BoucWen, displacement, z0: float = 0.0) -> np.ndarray:
    """The hysteretic variable along a displacement record, from ``z0`` at its first sample.

    Parameters
    ----------
    shape : BoucWen
    displacement : array_like, shape (n_samples, ...)
        The displacement the variable follows (relative for an element between two DOFs); axis 0
        is time, any further axes are independent records.
    z0 : float
        z at the first sample (0: a virgin state).

    Returns
    -------
    ndarray
        z, the shape of ``displacement``.
    """
    x = np.asarray(displacement, dtype=float)
    if x.ndim == 0:
        return np.full(x.shape, float(z0))
    if x.ndim == 1:
        return _path_1d(shape, x, z0)
    flat = x.reshape(len(x), -1)
    out = np.column_stack([_path_1d(shape, flat[:, j], z0) for j in range(flat.shape[1])])
    return out.reshape(x.shape)


def boucwen_periodic(shape: BoucWen, displacement) -> np.ndarray:
    """The periodic steady state of the hysteretic variable over one period of displacement (module notes).

    Parameters
    ----------
    shape : BoucWen
    displacement : array_like, shape (period, ...)
        One period; axis 0 is time.

    Returns
    -------
    ndarray
        z in periodic steady state (the path that starts where it ends, the step from the last
        sample back to the first included), the shape of ``displacement``.

    Raises
    ------
    NotIdentifiableError
        When z does not repeat within 200 passes over the period (no periodic steady state).
    """
    x = np.asarray(displacement, dtype=float)
    if x.ndim != 1:
        flat = x.reshape(len(x), -1)
        return np.column_stack([boucwen_periodic(shape, flat[:, j]) for j in range(flat.shape[1])]).reshape(x.shape)
    closed = np.append(x, x[:1])  # the period and the step back to its start
    starts = _runs(closed) if shape.n == 1.0 else None
    z0 = 0.0
    for _ in range(_PERIODIC_PASSES):
        if starts is None:
            path = _path_by_sample(shape, closed, z0)
            last, scale = float(path[-1]), float(np.max(np.abs(path)))
        else:  # z is monotone along a run: its largest |z| is at a run's end
            at_starts = _run_starts(shape, closed, starts, z0)
            last, scale = float(at_starts[-1]), float(np.max(np.abs(at_starts)))
        if not math.isfinite(scale):
            break
        if abs(last - z0) <= _PERIODIC_TOLERANCE * max(scale, np.finfo(float).tiny):
            return (path if starts is None else _path_1d(shape, closed, z0))[:-1]
        z0 = last
    raise NotIdentifiableError(
        f"the Bouc-Wen variable ({shape.text()}) reaches no periodic steady state over the period of this record"
    )


@dataclass(frozen=True)
class HysteresisReading:
    """The physical reading of an identified Bouc-Wen term ``λ z`` (docs/method.md §12).

    Attributes
    ----------
    stiffness : float
        Hysteretic stiffness λ [N/m]: the tangent stiffness of the element at z = 0.
    yield_displacement : float or None
        ``(β + γ)^(-1/n)`` [m]: where z levels off on loading; None when ``β + γ <= 0`` (it hardens).
    yield_force : float or None
        ``λ`` times the yield displacement [N].
    amplitude : float
        Displacement amplitude the loop is read at [m] (√2 times the rms of the measured displacement
        the term acts on: a sine with the record's rms).
    loop_area : float
        Energy dissipated per cycle of a sine of that amplitude, ``∮ λ z dx`` [J] (periodic steady state;
        negative when the loop runs the other way round: the element would feed energy in).
    peak_force : float
        Largest |λ z| on that loop [N].
    """

    stiffness: float
    yield_displacement: float | None
    yield_force: float | None
    amplitude: float
    loop_area: float
    peak_force: float

    def to_dict(self) -> dict:
        """The reading as plain numbers (results.json)."""
        return {
            "stiffness": self.stiffness, "yield_displacement": self.yield_displacement,
            "yield_force": self.yield_force, "amplitude": self.amplitude, "loop_area": self.loop_area,
            "peak_force": self.peak_force,
        }


def hysteresis_reading(shape: BoucWen, coefficient: float, displacement, points: int = 2048) -> HysteresisReading:
    """Hysteretic stiffness, yield and loop area per cycle at the measured amplitude (docs/method.md §12).

    Parameters
    ----------
    shape : BoucWen
        The term's shape.
    coefficient : float
        Its identified coefficient λ [N/m].
    displacement : array_like
        The measured displacement the term acts on (relative for an element), for the amplitude.
    points : int
        Samples per cycle of the sine the loop is computed on.

    Returns
    -------
    HysteresisReading
    """
    x = np.asarray(displacement, dtype=float).ravel()
    amplitude = float(np.sqrt(2.0) * np.std(x))
    sine = amplitude * np.sin(2 * np.pi * np.arange(points) / points)
    z = boucwen_periodic(shape, sine)
    lam = float(np.real(coefficient))
    closed_x, closed_z = np.append(sine, sine[:1]), np.append(z, z[:1])
    area = float(lam * np.sum(0.5 * (closed_z[1:] + closed_z[:-1]) * np.diff(closed_x)))
    yield_x = shape.yield_displacement
    return HysteresisReading(
        stiffness=lam, yield_displacement=yield_x, yield_force=None if yield_x is None else lam * yield_x,
        amplitude=amplitude, loop_area=area, peak_force=float(np.max(np.abs(lam * z))),
    )
