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


def _path_1d(shape: BoucWen, x: np.ndarray, z0: float) -> np.ndarray:
    """z along one displacement series, a scalar loop (the fast path of :func:`boucwen_path`)."""
    out = np.empty(len(x))
    if not len(x):
        return out
    z = float(z0)
    out[0] = z
    increments = np.diff(x).tolist()
    if shape.n != 1.0:
        for k, dx in enumerate(increments, start=1):
            if dx != 0.0:
                s = 1.0 if dx > 0 else -1.0
                z = s * float(_advance_general(np.float64(s * z), abs(dx), shape.beta, shape.gamma, shape.n))
            out[k] = z
        return out
    loading, unloading = shape.beta + shape.gamma, shape.beta - shape.gamma
    exp, expm1, log = math.exp, math.expm1, math.log
    values = [z]
    append = values.append
    for dx in increments:  # exact per branch (module notes); this loop runs for every sample of every identification
        if dx == 0.0:
            append(z)
            continue
        s, xi = (1.0, dx) if dx > 0 else (-1.0, -dx)
        w = s * z
        a = loading
        if w < 0.0:
            reach = 1.0 - unloading * w
            to_zero = (-w if unloading == 0.0 else log(reach) / unloading) if reach > 0.0 else math.inf
            if xi <= to_zero:
                a = unloading
            else:
                xi -= to_zero
                w = 0.0
        t = a * xi
        if t == 0.0:
            w += xi
        elif t > -700.0:
            w = w * exp(-t) - expm1(-t) / a
        else:
            w = _linear(w, xi, a)
        z = s * w
        append(z)
    out[:] = values
    return out


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
    z0 = 0.0
    for _ in range(_PERIODIC_PASSES):
        path = _path_1d(shape, closed, z0)
        scale = float(np.max(np.abs(path))) if np.all(np.isfinite(path)) else math.nan
        if not math.isfinite(scale):
            break
        if abs(path[-1] - z0) <= _PERIODIC_TOLERANCE * max(scale, np.finfo(float).tiny):
            return path[:-1]
        z0 = float(path[-1])
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
