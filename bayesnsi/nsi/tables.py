"""Paper-style tables (Tables 3-4, 6-7, 9-10) as pandas DataFrames."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

__all__ = ["modes_table", "coefficients_table"]


def _match(identified: np.ndarray, exact: np.ndarray) -> list[int | None]:
    """Index of the identified mode nearest to each exact mode (None if none within 5 %)."""
    out = []
    for f in exact:
        if len(identified) == 0:
            out.append(None)
            continue
        k = int(np.argmin(np.abs(identified - f)))
        out.append(k if abs(identified[k] / f - 1) < 0.05 else None)
    return out


def modes_table(results: Mapping, exact_frequencies_hz: Sequence[float] | None = None, exact_damping_ratios=None):
    """Identified natural frequencies and damping ratios per candidate (paper Tables 3, 6, 9).

    Parameters
    ----------
    results : mapping name -> NSIResult
    exact_frequencies_hz, exact_damping_ratios : sequence of float, optional
        Reference values; when given, rows follow them and errors [%] are added (a mode with no
        identified counterpart within 5 % shows as missing).

    Returns
    -------
    pandas.DataFrame
        Rows: quantities per mode; columns: (candidate, "identified" | "error %").
    """
    import pandas as pd

    data = {}
    if exact_frequencies_hz is None:
        n_modes = max(len(r.modes) for r in results.values())
        index = [f"{q} {k + 1}" for k in range(n_modes) for q in ("frequency [Hz]", "damping ratio [%]")]
        for name, res in results.items():
            values = []
            for k in range(n_modes):
                mode = res.modes[k] if k < len(res.modes) else None
                values += [mode.frequency_hz if mode else np.nan, 100 * mode.damping_ratio if mode else np.nan]
            data[(name, "identified")] = values
        return pd.DataFrame(data, index=index)
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
        ident = np.array(ident)
        data[(name, "identified")] = ident
        data[(name, "error %")] = 100 * (ident / np.array(data[("exact", "")]) - 1)
    return pd.DataFrame(data, index=index)


def coefficients_table(results: Mapping, exact: Mapping[str, float] | None = None):
    """Nonlinear coefficients per candidate (paper Tables 4, 7, 10).

    Parameters
    ----------
    results : mapping name -> NSIResult
    exact : mapping term name (``Term.name``) -> true value, optional

    Returns
    -------
    pandas.DataFrame
        Rows: terms; columns: (candidate, "identified" | "|Im|/|Re|" | "error %").
    """
    import pandas as pd

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
                100 * (by_term[t].value / exact[t] - 1) if t in by_term and exact.get(t) else np.nan for t in terms
            ]
    return pd.DataFrame(data, index=pd.Index(terms, name="term"))
