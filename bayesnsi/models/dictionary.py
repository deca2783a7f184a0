"""Dictionary of candidate effects for closing the loop (SPEC section 7, step 2)."""

from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from .terms import Term

__all__ = ["EFFECT_TYPES", "effect_dictionary", "clearance_expression", "default_gaps"]

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
    """
    dofs = sorted(set(int(d) for d in measured_dofs))
    if pairs is None:
        pairs = [(j, j + 1) for j in dofs if j + 1 in dofs]
    locations = [((k,), f"x{k}", f"v{k}") for k in dofs]
    locations += [((j, k), f"(x{j}-x{k})", f"(v{j}-v{k})") for j, k in pairs]
    out = []
    for at, x, v in locations:
        for name in types:
            out.append((name, Term(EFFECT_TYPES[name].format(x=x, v=v), at if len(at) == 2 else at[0])))
        for gap in (gaps or {}).get(at, ()):
            out.append((f"clearance g={gap:.3g}", Term(clearance_expression(x, gap), at if len(at) == 2 else at[0])))
    return out


def default_gaps(displacement_std: float, fractions=(0.5, 1.0, 1.5)) -> np.ndarray:
    """A gap grid as fractions of the displacement standard deviation at a location."""
    return np.asarray(fractions) * displacement_std
