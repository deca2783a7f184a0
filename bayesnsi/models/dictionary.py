"""Dictionary of candidate effects for closing the loop (SPEC section 7, step 2)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from .terms import Term

__all__ = [
    "EFFECT_TYPES",
    "clearance_effect",
    "clearance_expression",
    "clearance_gap",
    "default_gaps",
    "effect_base_type",
    "effect_dictionary",
]

EFFECT_TYPES: dict[str, str] = {
    "x^2": "{x}**2",
    "x|x|": "{x}*abs({x})",
    "x^3": "{x}**3",
    "sign(v)": "sign({v})",
    "v|v|": "{v}*abs({v})",
    "v^3": "{v}**3",
    "x^2 sign(v)": "{x}**2*sign({v})",
}
"""Effect types: name -> expression template in the displacement ``{x}`` and velocity ``{v}``."""


def clearance_expression(x: str, gap: float) -> str:
    """Clearance (dead-zone) spring ``max(0, |x| - g)·sign(x)`` written in the term grammar."""
    g = f"{gap:.6g}"
    return f"(abs({x})-{g})*(sign(abs({x})-{g})+1)/2*sign({x})"


def _location_symbols(at: tuple[int, ...]) -> tuple[str, str]:
    if len(at) == 2:
        return f"(x{at[0]}-x{at[1]})", f"(v{at[0]}-v{at[1]})"
    return f"x{at[0]}", f"v{at[0]}"


def clearance_effect(at, gap: float) -> tuple[str, Term]:
    """A clearance effect ``("clearance g=<gap>", Term)`` at DOF ``k`` or across a pair ``(j, k)``.

    Parameters
    ----------
    at : int or (int, int)
        Location (SPEC 1: grounded at DOF k, or an element between j and k acting on x_j - x_k).
    gap : float
        Gap g [m] of ``max(0, |x| - g)·sign(x)`` (SPEC 7, step 2).
    """
    at = (int(at),) if np.ndim(at) == 0 else tuple(int(a) for a in at)
    x, _ = _location_symbols(at)
    return f"clearance g={gap:.6g}", Term(clearance_expression(x, gap), at if len(at) == 2 else at[0])


def clearance_gap(effect_type: str) -> float | None:
    """The gap of a ``"clearance g=..."`` effect type, None for any other type."""
    if not effect_type.startswith("clearance g="):
        return None
    return float(effect_type.split("=", 1)[1])


def effect_base_type(effect_type: str) -> str:
    """The type without its parameter: ``"clearance g=0.01"`` -> ``"clearance"``."""
    return "clearance" if effect_type.startswith("clearance") else effect_type


def effect_dictionary(
    measured_dofs: Sequence[int],
    types: Iterable[str] = tuple(EFFECT_TYPES),
    gaps: dict[tuple[int, ...], Sequence[float]] | None = None,
    pairs: Sequence[tuple[int, int]] | None = None,
) -> list[tuple[str, Term]]:
    """Effects at each measured DOF and between neighbouring measured DOFs (SPEC 7).

    Parameters
    ----------
    measured_dofs : sequence of int
        DOFs whose displacement and velocity are available.
    types : iterable of str
        Keys of :data:`EFFECT_TYPES`.
    gaps : mapping location -> sequence of float, optional
        Clearance gaps [m] to try at each location (``(k,)`` or ``(j, k)``); none by default.
    pairs : sequence of (j, k), optional
        Element locations; default: consecutive DOF numbers that are both measured.

    Returns
    -------
    list of (effect type, Term)
        Clearances are typed ``"clearance g=<gap>"`` (:func:`clearance_gap` reads the gap back).
    """
    dofs = sorted(set(int(d) for d in measured_dofs))
    if pairs is None:
        pairs = [(j, j + 1) for j in dofs if j + 1 in dofs]
    locations = [(k,) for k in dofs] + [(int(j), int(k)) for j, k in pairs]
    out = []
    for at in locations:
        x, v = _location_symbols(at)
        for name in types:
            out.append((name, Term(EFFECT_TYPES[name].format(x=x, v=v), at if len(at) == 2 else at[0])))
        for gap in (gaps or {}).get(at, ()):
            out.append(clearance_effect(at, float(gap)))
    return out


def default_gaps(displacement_std: float, fractions=(0.5, 1.0, 1.5)) -> np.ndarray:
    """A gap grid as fractions of the displacement standard deviation at a location."""
    return np.asarray(fractions) * displacement_std
