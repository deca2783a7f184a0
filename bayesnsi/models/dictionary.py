"""Dictionary of candidate effects for closing the loop (docs/method.md §7, step 2)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import ConfigError
from .expressions import MEMORY
from .hysteresis import BoucWen
from .terms import Term

__all__ = [
    "CLEARANCE",
    "EFFECT_TYPES",
    "DEFAULT_EFFECT_TYPES",
    "Effect",
    "HARDENING_LIMIT",
    "HYSTERESIS",
    "MEMORY_RATIO",
    "SMOOTH_FRICTION",
    "DIRECTIONAL",
    "MIN_REVERSALS",
    "clearance_effect",
    "clearance_expression",
    "default_gaps",
    "default_shapes",
    "default_widths",
    "effect_dictionary",
    "hysteresis_effect",
    "hysteretic_shape",
    "smooth_friction_effect",
    "velocity_reversals",
]

EFFECT_TYPES: dict[str, str] = {
    "x^2": "{x}**2",
    "x|x|": "{x}*abs({x})",
    "x^3": "{x}**3",
    "sign(v)": "sign({v})",
    "v|v|": "{v}*abs({v})",
    "v^3": "{v}**3",
    "x^2 sign(v)": "{x}**2*sign({v})",
    "sign(v)+": "(1+sign({v}))/2",
    "v+": "{v}*(1+sign({v}))/2",
    "|v|": "abs({v})",
    "offset": "1",
}
"""Effect types: name -> expression template in the displacement ``{x}`` and velocity ``{v}``.

``sign(v)+`` and ``v+`` act in the positive direction of motion only: beside ``sign(v)`` (or a
viscous damper) they make friction asymmetric, ``F+`` moving forwards and ``F-`` backwards with
``λ_sign = F-`` and ``λ_sign+ = F+ - F-``. Asymmetric Coulomb friction differs from a constant force
only while the body is at rest, so on records that seldom stop the two cannot be told apart.
``offset`` is a constant force (its coefficient read from the FRF at DC); a record whose means were
removed leaves it nothing to explain. These three are not in :data:`DEFAULT_EFFECT_TYPES`.

``|v|`` is direction-dependent viscous friction written without a linear part: beside the linear
damping ``c·v`` of the identified model, ``λ|v|`` makes the viscous coefficient ``c + λ`` moving
forwards and ``c - λ`` backwards (:func:`bayesnsi.loop.friction_reading`). It is ``v+`` less its
linear half (``v·[v > 0] = (v + |v|)/2``): NSI identifies the linear damping with the linear part,
so a basis that holds ``v/2`` as well leaves the two to share it. Offered by default wherever the
velocity reverses often enough to inform it (:data:`DIRECTIONAL`). A Coulomb friction that differs by
direction (``sign(v)+`` beside ``sign(v)``) is Coulomb friction plus a constant force: its asymmetry
is the offset, read with the free body's linear part (docs/method.md §11)."""

DEFAULT_EFFECT_TYPES: tuple[str, ...] = ("x^2", "x|x|", "x^3", "sign(v)", "v|v|", "v^3", "x^2 sign(v)", "|v|")
"""The types a dictionary holds unless others are asked for (``[diagnose] effects``)."""

DIRECTIONAL: tuple[str, ...] = ("|v|", "v+", "sign(v)+")
"""Types that compare the two directions of motion: offered only where the velocity reverses at least
:data:`MIN_REVERSALS` times in each half of the record (:func:`velocity_reversals`)."""

MIN_REVERSALS = 2
"""Fewest reversals of the velocity in each half of the record for a :data:`DIRECTIONAL` effect at a
location: each half then holds a motion forwards and one backwards, so that the record-halves check
compares like with like (the EMPS axis: 7 reversals in 25 s, 3 and 4 per half)."""

CLEARANCE = "clearance"
"""Type of a clearance (dead-zone) spring, whose gap is a parameter (:func:`clearance_effect`)."""

SMOOTH_FRICTION = "tanh(v/eps)"
"""Type of a smoothed Coulomb friction ``tanh(v/ε)`` whose width ε [m/s] is a parameter fixed from
the data (:func:`default_widths`, :func:`smooth_friction_effect`). Unlike ``sign(v)`` it is smooth,
so a frequency-route model holding it has a periodic steady state (harmonic balance); its
coefficient is the friction force reached at |v| >> ε."""


HYSTERESIS = MEMORY
"""Type of a Bouc-Wen hysteretic element ``boucwen(x, beta=.., gamma=..)`` whose shape parameters are
gridded from the data (:func:`default_shapes`, :func:`hysteresis_effect`; docs/method.md §12). Its
coefficient is the hysteretic stiffness λ [N/m]."""

SHAPE_LOADING: tuple[float, ...] = (-0.25, 0.5, 2.0)
"""``(β + γ)`` of the default Bouc-Wen grid times the std of the displacement it acts on: the loading
branch ``dz/dx = 1 - (β + γ) z`` hardens gently (-0.25), or levels off at twice or half the std."""
SHAPE_UNLOADING: tuple[float, ...] = (1.0, 3.0, 9.0)
"""``(β - γ)`` of the default grid times the displacement std: the unloading branch ``dz/dx = 1 + (β - γ) |z|``
stiffens over about one std, a third or a ninth of it (dissipation needs β > 0: unloading above loading)."""
HARDENING_LIMIT = 0.3
"""Least ``(β + γ)`` times the displacement std a Bouc-Wen shape may have (grid and refinement): a loading
branch that hardens faster grows exponentially over the record, a basis function, not hysteresis."""
MEMORY_RATIO = 0.5
"""Least β/|γ| of a Bouc-Wen shape (grid and refinement): with β → 0 the law is elastic, ``dz/dx = 1 - γ |z|``,
a static spring the dictionary already offers (x|x|, x³, clearances) with no memory to speak of; on a
hardening branch it means the unloading branch stiffens at least three times as fast as loading hardens."""


def hysteretic_shape(shape: BoucWen, displacement_std: float) -> bool:
    """True for a shape the loop offers: β > 0, β >= |γ|/2 and a loading branch within the hardening limit.

    Parameters
    ----------
    shape : BoucWen
    displacement_std : float
        Std of the displacement it acts on [m].

    Returns
    -------
    bool
    """
    return (shape.beta > 0 and shape.beta >= MEMORY_RATIO * abs(shape.gamma)
            and shape.loading * displacement_std >= -HARDENING_LIMIT)


def default_shapes(displacement_std: float, loading=SHAPE_LOADING, unloading=SHAPE_UNLOADING) -> list[BoucWen]:
    """The Bouc-Wen shapes (n = 1) of the loop's grid at a location (docs/method.md §12).

    Parameters
    ----------
    displacement_std : float
        Standard deviation of the displacement the element acts on (relative for a pair) [m].
    loading, unloading : sequence of float
        ``β + γ`` and ``β - γ`` times ``displacement_std`` (:data:`SHAPE_LOADING`,
        :data:`SHAPE_UNLOADING`); pairs that are not :func:`hysteretic_shape` are left out.

    Returns
    -------
    list of BoucWen
        One per (loading, unloading) pair, 3 significant digits.
    """
    out = []
    for c in loading:
        for u in unloading:
            shape = BoucWen.from_branches(c / displacement_std, u / displacement_std)
            if hysteretic_shape(shape, displacement_std):
                out.append(BoucWen(float(f"{shape.beta:.3g}"), float(f"{shape.gamma:.3g}")))
    return out


def hysteresis_effect(at, shape: BoucWen) -> Effect:
    """A Bouc-Wen hysteretic element at DOF ``k`` (on x_k) or across a pair ``(j, k)`` (on x_j - x_k).

    Parameters
    ----------
    at : int or (int, int)
        Location.
    shape : BoucWen
        Its shape, written in the term with 3 significant digits
        (``"boucwen(x1-x2,beta=150,gamma=-50)"``), so that the term in results.json parses back as
        it was identified.

    Returns
    -------
    Effect
    """
    at = (int(at),) if np.ndim(at) == 0 else tuple(int(a) for a in at)
    x = f"x{at[0]}-x{at[1]}" if len(at) == 2 else f"x{at[0]}"
    shape = BoucWen(float(f"{shape.beta:.3g}"), float(f"{shape.gamma:.3g}"), float(f"{shape.n:.3g}"))
    return Effect(HYSTERESIS, Term(f"{MEMORY}({x},{shape.text()})", at if len(at) == 2 else at[0]), shape=shape)


def smooth_friction_effect(at, eps: float) -> Effect:
    """A smoothed friction effect ``tanh(v/ε)`` at DOF ``k`` or across a pair ``(j, k)``.

    Parameters
    ----------
    at : int or (int, int)
        Location (grounded at DOF k, or an element between j and k acting on v_j - v_k).
    eps : float
        Width ε > 0 [m/s], kept to 3 significant digits and written as a number in the term
        (``"tanh((v7-v8)/0.00455)"``), so the expression in results.json is reproducible.

    Returns
    -------
    Effect

    Raises
    ------
    ConfigError
        For a width that is not a positive finite number.
    """
    if not (np.isfinite(eps) and eps > 0):
        raise ConfigError(f"the width of a tanh(v/eps) friction must be a positive number, got {eps!r}")
    at = (int(at),) if np.ndim(at) == 0 else tuple(int(a) for a in at)
    _, v = _location_symbols(at)
    eps = float(f"{eps:.3g}")
    return Effect(SMOOTH_FRICTION, Term(f"tanh({v}/{eps:.3g})", at if len(at) == 2 else at[0]), eps=eps)


def clearance_expression(x: str, gap: float) -> str:
    """Clearance (dead-zone) spring ``max(0, |x| - g)·sign(x)`` written in the term grammar.

    Parameters
    ----------
    x : str
        The displacement it acts on, e.g. ``"x1"`` or ``"(x1-x2)"``.
    gap : float
        Half-width g of the dead zone [m], written with 6 significant digits.

    Returns
    -------
    str
        The expression text, for :func:`bayesnsi.models.parse_expression`.
    """
    g = f"{gap:.6g}"
    return f"(abs({x})-{g})*(sign(abs({x})-{g})+1)/2*sign({x})"


def _location_symbols(at: tuple[int, ...]) -> tuple[str, str]:
    if len(at) == 2:
        return f"(x{at[0]}-x{at[1]})", f"(v{at[0]}-v{at[1]})"
    return f"x{at[0]}", f"v{at[0]}"


@dataclass(frozen=True)
class Effect:
    """One effect of the dictionary: a type, a location (in its term) and the type's parameters.

    Attributes
    ----------
    base : str
        Key of :data:`EFFECT_TYPES`, or ``"clearance"``.
    term : Term
        The effect's basis function with its location.
    gap : float or None
        Gap g [m] of a clearance (6 significant digits, as written in its term); None otherwise.
    eps : float or None
        Width ε [m/s] of a ``tanh(v/eps)`` friction (3 significant digits, as written); None otherwise.
    shape : BoucWen or None
        Shape of a Bouc-Wen element (as written in its term); None otherwise.
    """

    base: str
    term: Term
    gap: float | None = None
    eps: float | None = None
    shape: BoucWen | None = None

    def __post_init__(self) -> None:
        if self.base not in (CLEARANCE, SMOOTH_FRICTION, HYSTERESIS) and self.base not in EFFECT_TYPES:
            raise ConfigError(
                f"effect type {self.base!r} unknown; choose from "
                f"{[*EFFECT_TYPES, CLEARANCE, SMOOTH_FRICTION, HYSTERESIS]}"
            )
        if (self.base == HYSTERESIS) != (self.shape is not None):
            raise ConfigError(
                f"a shape is given with, and only with, a {HYSTERESIS} effect; got {self.base!r}, shape {self.shape!r}"
            )
        if (self.base == CLEARANCE) != (self.gap is not None):
            raise ConfigError(
                f"a gap is given with, and only with, a clearance effect; got {self.base!r}, gap {self.gap!r}"
            )
        if (self.base == SMOOTH_FRICTION) != (self.eps is not None):
            raise ConfigError(
                f"a width is given with, and only with, a {SMOOTH_FRICTION} effect; got {self.base!r}, eps {self.eps!r}"
            )

    @property
    def location(self) -> tuple[int, ...]:
        """``(k,)`` or ``(j, k)``: where the effect acts."""
        return tuple(self.term.at)

    @property
    def name(self) -> str:
        """The type with its parameter, e.g. ``"x^3"``, ``"clearance g=0.015"`` or ``"tanh(v/eps) eps=0.00455"``."""
        if self.eps is not None:
            return f"{SMOOTH_FRICTION} eps={self.eps:.3g}"
        if self.shape is not None:
            return f"{HYSTERESIS} {self.shape.text().replace(',', ' ')}"
        return f"{CLEARANCE} g={self.gap:.6g}" if self.gap is not None else self.base

    def __str__(self) -> str:
        return f"{self.name} {self.term.name}"


def clearance_effect(at, gap: float) -> Effect:
    """A clearance effect at DOF ``k`` or across a pair ``(j, k)``.

    Parameters
    ----------
    at : int or (int, int)
        Location (docs/method.md §1: grounded at DOF k, or an element between j and k acting on x_j - x_k).
    gap : float
        Gap g [m] of ``max(0, |x| - g)·sign(x)`` (docs/method.md §7, step 2), kept to 6 significant digits.

    Returns
    -------
    Effect
    """
    at = (int(at),) if np.ndim(at) == 0 else tuple(int(a) for a in at)
    x, _ = _location_symbols(at)
    gap = float(f"{gap:.6g}")
    return Effect(CLEARANCE, Term(clearance_expression(x, gap), at if len(at) == 2 else at[0]), gap)


def effect_dictionary(
    measured_dofs: Sequence[int],
    types: Iterable[str] = DEFAULT_EFFECT_TYPES,
    gaps: dict[tuple[int, ...], Sequence[float]] | None = None,
    pairs: Sequence[tuple[int, int]] | None = None,
    widths: dict[tuple[int, ...], Sequence[float]] | None = None,
    shapes: dict[tuple[int, ...], Sequence[BoucWen]] | None = None,
) -> list[Effect]:
    """Effects at each measured DOF and between pairs of measured DOFs (docs/method.md §7).

    Parameters
    ----------
    measured_dofs : sequence of int
        DOFs whose displacement and velocity are available.
    types : iterable of str
        Keys of :data:`EFFECT_TYPES`.
    gaps : mapping location -> sequence of float, optional
        Clearance gaps [m] to try at each location (``(k,)`` or ``(j, k)``); none by default.
    pairs : sequence of (j, k), optional
        Element locations; default: every pair of measured DOFs (which sensors an element joins
        is not known from their numbers: on a ground vibration test the joint is between the wing
        and payload sensors, whatever they are called).
    widths : mapping location -> sequence of float, optional
        Widths ε [m/s] of the ``tanh(v/eps)`` frictions to try at each location; none by default.
    shapes : mapping location -> sequence of BoucWen, optional
        Bouc-Wen elements to try at each location; none by default.

    Returns
    -------
    list of Effect
        Per location, the ``types`` in order, then its clearances, its tanh frictions, its Bouc-Wen elements.

    Raises
    ------
    ConfigError
        For a type that is not a key of :data:`EFFECT_TYPES`.
    """
    types = tuple(types)
    unknown = [name for name in types if name not in EFFECT_TYPES]
    if unknown:
        raise ConfigError(f"unknown effect type(s) {unknown}; choose from {list(EFFECT_TYPES)}")
    dofs = sorted(set(int(d) for d in measured_dofs))
    if pairs is None:
        pairs = [(j, k) for i, j in enumerate(dofs) for k in dofs[i + 1 :]]
    locations = [(k,) for k in dofs] + [(int(j), int(k)) for j, k in pairs]
    out = []
    for at in locations:
        x, v = _location_symbols(at)
        for name in types:
            out.append(Effect(name, Term(EFFECT_TYPES[name].format(x=x, v=v), at if len(at) == 2 else at[0])))
        for gap in (gaps or {}).get(at, ()):
            out.append(clearance_effect(at, float(gap)))
        for eps in (widths or {}).get(at, ()):
            out.append(smooth_friction_effect(at, float(eps)))
        for shape in (shapes or {}).get(at, ()):
            out.append(hysteresis_effect(at, shape))
    return out


def default_gaps(displacement_std: float, fractions=(0.5, 1.0, 1.5)) -> np.ndarray:
    """A gap grid as fractions of the displacement standard deviation at a location.

    Parameters
    ----------
    displacement_std : float
        Standard deviation of the displacement at the location [m].
    fractions : sequence of float
        The gaps as fractions of ``displacement_std``.

    Returns
    -------
    numpy.ndarray
        The gaps [m], one per fraction.
    """
    return np.asarray(fractions) * displacement_std


def default_widths(velocity_std: float, fractions=(0.25, 0.5)) -> np.ndarray:
    """The widths ε of ``tanh(v/eps)`` frictions as fractions of the velocity standard deviation.

    A width well below the velocity spread makes ``tanh(v/ε)`` a Coulomb friction that is smooth
    through the reversals; 0.25 and 0.5 std bracket the joint of the simulated GVT
    (``tanh(v/0.002)``, std of the relative velocity 0.018 m/s at 1 N: ε = 0.0046 and 0.0091).

    Parameters
    ----------
    velocity_std : float
        Standard deviation of the velocity the friction acts on (relative velocity for a pair) [m/s].
    fractions : sequence of float
        The widths as fractions of ``velocity_std``.

    Returns
    -------
    numpy.ndarray
        The widths [m/s], one per fraction.
    """
    return np.asarray(fractions) * velocity_std


def velocity_reversals(velocity, hysteresis: float = 0.05) -> int:
    """How often a velocity changes direction, with a dead band against noise.

    A reversal is counted when the velocity crosses from above ``+h`` to below ``-h`` or back, with
    ``h = hysteresis · std(velocity)``: sensor noise about a standstill does not count.

    Parameters
    ----------
    velocity : array_like, shape (n,)
        The velocity at a location (relative velocity for a pair) [m/s].
    hysteresis : float
        Half-width of the dead band as a fraction of the velocity's standard deviation.

    Returns
    -------
    int
        The number of reversals.
    """
    v = np.asarray(velocity, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if v.size < 2:
        return 0
    h = hysteresis * float(np.std(v))
    state = np.where(v > h, 1, np.where(v < -h, -1, 0))
    signs = state[state != 0]
    return int(np.count_nonzero(np.diff(signs)))
