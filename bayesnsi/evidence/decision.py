"""How sure the selection is: each candidate against the selected one, as Bayes factors (docs/method.md §6).

The log Bayes factor of the selected model ``s`` against candidate ``c`` is
``log B = log Z_s - log Z_c`` [nat]; with the prior odds it gives the posterior odds
``P(s|D)/P(c|D) = B · P(s)/P(c)``. Its Monte-Carlo standard error is
``sqrt(se_s² + se_c²)`` (the two estimates are independent runs). The words follow Kass and
Raftery (J. Am. Stat. Assoc. 90, 1995, p. 777) on the natural-log scale: below 1 nat "barely
worth mentioning", 1-3 "positive", 3-5 "strong", above 5 "very strong".
"""

from __future__ import annotations

import numpy as np

from ..exceptions import InputDataError

__all__ = ["STRENGTH_NAT", "decision_table", "evidence_strength"]

STRENGTH_NAT = ((1.0, "barely worth mentioning"), (3.0, "positive"), (5.0, "strong"), (np.inf, "very strong"))
"""Upper bounds [nat] of the log Bayes factor for each word of Kass and Raftery (1995)."""


def evidence_strength(log_bayes_factor: float) -> str:
    """Kass and Raftery's word for a log Bayes factor [nat] in favour of the selected model.

    Parameters
    ----------
    log_bayes_factor : float
        ``log Z_selected - log Z_other``; +inf when the other candidate failed.

    Returns
    -------
    str
        E.g. ``"strong"``; ``"none: the data favour this candidate"`` for a negative value (the
        reference is not the most probable one, e.g. the loop's starting model), ``""`` for NaN.
    """
    value = float(log_bayes_factor)
    if np.isnan(value):
        return ""
    if value < 0:
        return "none: the data favour this candidate"
    return next(word for bound, word in STRENGTH_NAT if value < bound or np.isinf(bound))


def decision_table(table, likelihood: str, selected: str | None = None):
    """Each candidate against the selected one under the evidence of ``likelihood``.

    Parameters
    ----------
    table : pandas.DataFrame
        A :func:`~bayesnsi.evidence.ranking_table` (index: candidates; columns ``prior``,
        ``log_evidence_<likelihood>``, ``log_evidence_se_<likelihood>``, ``p_<likelihood>``,
        ``p_<likelihood>_sd`` and, when computed, ``log_likelihood_plain`` and ``p_plain``).
    likelihood : str
        Which evidence decides (``EvidenceOptions.likelihood``).
    selected : str, optional
        The selected candidate (default: the most probable one).

    Returns
    -------
    pandas.DataFrame
        Index: candidates, most probable first (then by log evidence). Columns: ``probability``, ``probability_sd``,
        ``log_evidence``, ``log_evidence_se``, ``log_bayes_factor`` (selected against this
        candidate; 0 for the selected one, +inf against a failed one), ``log_bayes_factor_se``,
        ``posterior_odds`` (``P(selected)/P(this)``), ``strength`` (:func:`evidence_strength`;
        "failed (no evidence)" for a candidate without one) and, with the plain ranking,
        ``delta_log_likelihood_plain`` (selected minus this).

    Raises
    ------
    InputDataError
        When the table has no evidence of ``likelihood`` or ``selected`` is not in it.
    """
    import pandas as pd

    log_z_col, se_col, p_col = f"log_evidence_{likelihood}", f"log_evidence_se_{likelihood}", f"p_{likelihood}"
    if log_z_col not in table.columns or p_col not in table.columns:
        raise InputDataError(f"the ranking table has no evidence for the likelihood {likelihood!r}")
    probability = table[p_col].to_numpy(dtype=float)
    if selected is None:
        if not np.any(np.isfinite(probability)):
            raise InputDataError("no candidate has an evidence to select it by")
        selected = str(table.index[int(np.nanargmax(probability))])
    if selected not in table.index:
        raise InputDataError(f"selected candidate {selected!r} is not in the ranking table")
    log_z = table[log_z_col].to_numpy(dtype=float)
    se = table[se_col].to_numpy(dtype=float) if se_col in table.columns else np.zeros_like(log_z)
    k = list(table.index).index(selected)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):  # odds of a probability ~1e-300: inf
        log_bf = np.where(np.isfinite(log_z), log_z[k] - log_z, np.inf)
        bf_se = np.where(np.isfinite(log_z), np.hypot(se[k], se), np.nan)
        odds = probability[k] / probability
    log_bf[k], bf_se[k], odds[k] = 0.0, 0.0, 1.0
    out = pd.DataFrame(
        {
            "probability": probability,
            "probability_sd": table[f"{p_col}_sd"].to_numpy(dtype=float) if f"{p_col}_sd" in table else 0.0,
            "log_evidence": log_z,
            "log_evidence_se": se,
            "log_bayes_factor": log_bf,
            "log_bayes_factor_se": bf_se,
            "posterior_odds": odds,
            "strength": [
                "selected" if i == k else evidence_strength(v) if np.isfinite(z) else "failed (no evidence)"
                for i, (v, z) in enumerate(zip(log_bf, log_z))
            ],
        },
        index=table.index,
    )
    if "log_likelihood_plain" in table.columns:
        plain = table["log_likelihood_plain"].to_numpy(dtype=float)
        out["delta_log_likelihood_plain"] = plain[k] - plain
    # most probable first; among probabilities that underflow to 0, the larger evidence first
    order = np.lexsort((-np.nan_to_num(log_z, nan=-np.inf), -np.nan_to_num(probability, nan=-1.0)))
    return out.iloc[order]
