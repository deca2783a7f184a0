"""Paper-style tables of identified models (Tables 3-4, 6-7, 9-10) as pandas DataFrames.

The numbers come from :class:`bayesnsi.nsi.NSIResult` (its ``modes`` and ``coefficients``);
this module only arranges them, so the numerical layer ``bayesnsi.nsi`` needs no pandas.

Example
-------
>>> from bayesnsi import NSIOptions, identify, simulate_case
>>> from bayesnsi.tables import coefficients_frame, coefficients_table, modes_frame, modes_table
>>> case = simulate_case("two-dof", seed=0)
>>> result = identify(case.signals, case.candidates[0], NSIOptions(block_rows=60, order=4))
>>> table = modes_table({"model 1": result}, case.exact_frequencies_hz, case.exact_damping_ratios)
>>> round(float(table.loc["frequency 1 [Hz]", ("model 1", "identified")]), 2)
2.46
>>> round(float(coefficients_table({"model 1": result}).iloc[0, 0]), 1)
20.0
>>> list(modes_frame(result).columns), coefficients_frame(result).index.name
(['frequency_hz', 'damping_ratio'], 'term')
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from .nsi import NSIResult

__all__ = ["modes_table", "coefficients_table", "modes_frame", "coefficients_frame", "physical_table"]


def _match(identified: np.ndarray, exact: np.ndarray) -> list[int | None]:
    """Index of the identified mode nearest to each exact mode (None if none within 5 %)."""
    out: list[int | None] = []
    for f in exact:
        if len(identified) == 0:
            out.append(None)
            continue
        k = int(np.argmin(np.abs(identified - f)))
        out.append(k if abs(identified[k] / f - 1) < 0.05 else None)
    return out


def _modes_by_rank(results: Mapping[str, NSIResult]) -> pd.DataFrame:
    """Frequency and damping of each result's k-th mode, rows ``frequency [Hz] k``, ``damping ratio [%] k``."""
    n_modes = max(len(r.modes) for r in results.values())
    index = [f"{q} {k + 1}" for k in range(n_modes) for q in ("frequency [Hz]", "damping ratio [%]")]
    data = {}
    for name, res in results.items():
        values = []
        for k in range(n_modes):
            mode = res.modes[k] if k < len(res.modes) else None
            values += [mode.frequency_hz if mode else np.nan, 100 * mode.damping_ratio if mode else np.nan]
        data[(name, "identified")] = values
    return pd.DataFrame(data, index=index)


def modes_table(
    results: Mapping[str, NSIResult],
    exact_frequencies_hz: Sequence[float] | None = None,
    exact_damping_ratios: Sequence[float] | None = None,
) -> pd.DataFrame:
    """Identified natural frequencies and damping ratios per candidate (paper Tables 3, 6, 9).

    Parameters
    ----------
    results : mapping of str to NSIResult
        Candidate name -> its identified model.
    exact_frequencies_hz : sequence of float, optional
        Reference natural frequencies [Hz]; when given, rows follow them and errors [%] are
        added (a mode with no identified counterpart within 5 % shows as missing).
    exact_damping_ratios : sequence of float, optional
        Reference damping ratios (fractions), one per reference frequency.

    Returns
    -------
    pandas.DataFrame
        Rows: quantities per mode; columns: (candidate, "identified" | "error %").
    """
    if exact_frequencies_hz is None:
        return _modes_by_rank(results)
    data: dict[tuple[str, str], Any] = {}
    exact_f = np.asarray(exact_frequencies_hz, dtype=float)
    exact_z = None if exact_damping_ratios is None else 100 * np.asarray(exact_damping_ratios, dtype=float)
    index = [f"frequency {k + 1} [Hz]" for k in range(len(exact_f))]
    if exact_z is not None:
        index += [f"damping ratio {k + 1} [%]" for k in range(len(exact_f))]
    data[("exact", "")] = list(exact_f) + ([] if exact_z is None else list(exact_z))
    for name, res in results.items():
        f = np.array([m.frequency_hz for m in res.modes])
        z = np.array([100 * m.damping_ratio for m in res.modes])
        pick = _match(f, exact_f)
        ident = [f[k] if k is not None else np.nan for k in pick]
        if exact_z is not None:
            ident += [z[k] if k is not None else np.nan for k in pick]
        identified = np.array(ident)
        data[(name, "identified")] = identified
        data[(name, "error %")] = 100 * (identified / np.array(data[("exact", "")]) - 1)
    return pd.DataFrame(data, index=index)


def coefficients_table(results: Mapping[str, NSIResult], exact: Mapping[str, float] | None = None) -> pd.DataFrame:
    """Nonlinear coefficients per candidate (paper Tables 4, 7, 10).

    Parameters
    ----------
    results : mapping of str to NSIResult
        Candidate name -> its identified model.
    exact : mapping of str to float, optional
        Term name (``Term.name``) -> true value; when given, errors [%] are added.

    Returns
    -------
    pandas.DataFrame
        Rows: terms; columns: (candidate, "identified" | "|Im|/|Re|" | "error %").
    """
    terms = []
    for res in results.values():
        for c in res.coefficients:
            if c.term.name not in terms:
                terms.append(c.term.name)
    data = {}
    if exact:
        data[("exact", "")] = [exact.get(t, np.nan) for t in terms]
    for name, res in results.items():
        by_term = {c.term.name: c for c in res.coefficients}
        data[(name, "identified")] = [by_term[t].value if t in by_term else np.nan for t in terms]
        data[(name, "|Im|/|Re|")] = [by_term[t].imag_ratio if t in by_term else np.nan for t in terms]
        if exact:
            data[(name, "error %")] = [
                100 * (by_term[t].value / exact[t] - 1) if t in by_term and exact.get(t) else np.nan
                for t in terms
            ]
    return pd.DataFrame(data, index=pd.Index(terms, name="term"))


def modes_frame(result: NSIResult) -> pd.DataFrame:
    """Modes of one identified model, one row per mode (paper Tables 3, 6, 9).

    Parameters
    ----------
    result : NSIResult
        Identified model.

    Returns
    -------
    pandas.DataFrame
        Columns ``frequency_hz``, ``damping_ratio``; index ``mode`` from 1.
    """
    return pd.DataFrame(
        {
            "frequency_hz": [m.frequency_hz for m in result.modes],
            "damping_ratio": [m.damping_ratio for m in result.modes],
        },
        index=pd.RangeIndex(1, len(result.modes) + 1, name="mode"),
    )


def coefficients_frame(result: NSIResult) -> pd.DataFrame:
    """Coefficients of one identified model, one row per term (paper Tables 4, 7, 10).

    Parameters
    ----------
    result : NSIResult
        Identified model.

    Returns
    -------
    pandas.DataFrame
        Columns ``value``, ``imag_ratio``, ``spread``; index ``term``.
    """
    return pd.DataFrame(
        {
            "value": [c.value for c in result.coefficients],
            "imag_ratio": [c.imag_ratio for c in result.coefficients],
            "spread": [c.spread for c in result.coefficients],
        },
        index=pd.Index([c.term.name for c in result.coefficients], name="term"),
    )


def physical_table(results: Mapping[str, NSIResult]) -> pd.DataFrame:
    """Mass, viscous damping and stiffness of one-DOF candidates, and their rigid-body poles.

    The lumped parameters come from the identified FRF (:attr:`NSIResult.physical_parameters`,
    any virtual spring of a free body removed); models with more DOFs have none and are left out.

    Parameters
    ----------
    results : mapping of str to NSIResult
        Candidate name -> its identified model.

    Returns
    -------
    pandas.DataFrame
        Rows: mass [kg], viscous damping [N s/m], stiffness [N/m], rigid-body poles; one column per
        one-DOF candidate (empty when there is none).
    """
    data = {}
    for name, res in results.items():
        if not res.physical_parameters:
            continue
        (phys,) = res.physical_parameters
        poles = ", ".join(f"{p.real:.3g}" for p in res.rigid_body_poles) or "-"
        data[name] = [phys.mass, phys.damping, phys.stiffness, poles]
    index = ["mass [kg]", "viscous damping [N s/m]", "stiffness [N/m]", "rigid-body poles s [1/s]"]
    return pd.DataFrame(data, index=index)
