"""Words and numbers as the report and the terminal show them: one wording for every surface.

Intervals with the digits their width needs, Monte-Carlo errors with two significant digits, a
posterior probability that never claims certainty, terms by readable names with units, and
settings as the TOML a config would hold.
"""

from __future__ import annotations

import math
import re

from ..io.units import ChannelUnits, term_unit

__all__ = [
    "INTERVAL_LABELS", "format_interval", "options_toml", "probability_text", "term_label", "value_with_error",
]

INTERVAL_LABELS = {"segments": "windows + posterior", "noise": "noise replicates + posterior",
                   "surrogate": "model replicates + posterior", "posterior": "posterior only, given the linear part"}
"""How each interval method is named beside an interval."""


def format_interval(ci, scale: float = 1.0) -> str:
    """``[lo, hi]`` with the digits that show the width (two significant digits of it, at least three).

    Parameters
    ----------
    ci : sequence of two floats
    scale : float
        Factor applied to both bounds (e.g. 100 for a damping ratio in percent).

    Returns
    -------
    str
        ``"—"`` when a bound is not finite.
    """
    lo, hi = float(ci[0]) * scale, float(ci[1]) * scale
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "—"
    span, size = abs(hi - lo), max(abs(lo), abs(hi))
    digits = 3 if span == 0.0 or size == 0.0 else min(12, max(3, math.ceil(math.log10(size / span)) + 2))
    return f"[{lo:.{digits}g}, {hi:.{digits}g}]"


def value_with_error(value: float, error: float, max_decimals: int = 4) -> str:
    """A Monte-Carlo estimate with its error: two significant digits of the error, the value to the same place.

    Parameters
    ----------
    value, error : float
    max_decimals : int
        At most this many decimals; an error below that resolution is shown as ``< 0.0001``.

    Returns
    -------
    str
        E.g. ``"13,081.16 ± 0.012"``, ``"183.5771 ± 0.0002"``, ``"12.0000 (± < 0.0001)"``.
    """
    value, error = float(value), float(error)
    if not math.isfinite(value):
        return "—" if math.isnan(value) else ("∞" if value > 0 else "-∞")
    if not math.isfinite(error) or error <= 0:
        return f"{value:,.1f}" if abs(value) >= 1000 else f"{value:.4g}"
    decimals = max(0, 1 - math.floor(math.log10(error)))  # two significant digits of the error
    if decimals > max_decimals:
        shown = round(error, max_decimals)
        spread = f"± {shown:.{max_decimals}f}" if shown > 0 else f"(± < {10.0 ** -max_decimals:.{max_decimals}f})"
        return f"{value:,.{max_decimals}f} {spread}"
    return f"{value:,.{decimals}f} ± {error:.2g}"


def probability_text(p: float) -> str:
    """A posterior probability as text that does not claim certainty: ``> 0.9999``, ``< 0.0001``.

    Parameters
    ----------
    p : float

    Returns
    -------
    str
    """
    if p != p:
        return "—"
    if p == 0.0:
        return "0"
    if p > 0.9999:
        return "> 0.9999"
    if p < 1e-4:
        return "< 0.0001"
    return f"{p:.4f}"


_CLEARANCE = re.compile(r"^\(abs\((?P<x>[^()]+|\([^()]+\))\)-(?P<g>[-+.\deE]+)\)\*\(sign\(abs\((?P=x)\)-(?P=g)\)\+1\)"
                        r"/2\*sign\((?P=x)\)$")
_SMOOTH = re.compile(r"^tanh\((?P<v>[^()]+|\([^()]+\))/(?P<eps>[-+.\deE]+)\)$")


def term_label(name: str, units: ChannelUnits | None = None) -> str:
    """A term by a readable name, with the unit of its coefficient when the data state units.

    Parameters
    ----------
    name : str
        The term's name (``expr@at``), e.g. ``"(abs(x1)-0.002)*(sign(abs(x1)-0.002)+1)/2*sign(x1)@1"``.
    units : ChannelUnits, optional

    Returns
    -------
    str
        E.g. ``"clearance of x1, gap 0.002 m @1 [N/m]"``, ``"tanh(v1/0.01) @1 [N]"``, ``"x1**3@1 [N/m^3]"``.
    """
    units = units or ChannelUnits()
    expr, _, at = name.rpartition("@")
    expr = expr or name
    where = f"@{at}" if at else ""
    if (match := _CLEARANCE.match(expr)) is not None:
        unit = f"{units.force}/{units.displacement}" if units.force and units.displacement else ""
        gap_unit = f" {units.displacement}" if units.displacement else ""
        label = f"clearance of {match['x']}, gap {float(match['g']):.4g}{gap_unit} {where}"
    elif (match := _SMOOTH.match(expr)) is not None:
        unit = units.force
        label = f"smoothed friction tanh({match['v']}/{float(match['eps']):.3g}) {where}"
    else:
        unit, label = term_unit(expr, units), f"{expr}{where}"
    return f"{label} [{unit}]" if unit else label


def options_toml(nsi, evidence=None, loop=None) -> str:
    """The settings as the ``[nsi]``, ``[evidence]`` and ``[diagnose]`` tables of a config (TOML).

    Parameters
    ----------
    nsi : NSIOptions
    evidence : EvidenceOptions, optional
    loop : LoopOptions, optional

    Returns
    -------
    str
        Options left at None are written as comments (TOML has no null).
    """
    from ..io._toml import dumps

    tables = {}
    comments = []
    for section, options in (("nsi", nsi), ("evidence", evidence), ("diagnose", loop)):
        if options is None:
            continue
        values = options.to_dict()
        tables[section] = {k: v for k, v in values.items() if v is not None}
        comments += [f"# [{section}] {k} = none" for k, v in values.items() if v is None]
    return dumps(tables).rstrip() + ("\n" + "\n".join(comments) if comments else "")
