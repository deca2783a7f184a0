"""Tables of the report with readable headers: the library's frames renamed and worded, nothing computed."""

from __future__ import annotations

__all__ = [
    "adequacy_frame", "decision_frame", "loop_frame", "model_check_frame", "probability_text", "ranking_frame",
    "summary_frame",
]

_LIKELIHOOD = {"white": "white", "ar1": "AR(1)", "arP": "AR(P)"}


def probability_text(p: float) -> str:
    """A posterior probability as text that does not claim certainty: ``> 0.9999``, ``< 1e-4``.

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


def decision_frame(decision, selected: str):
    """The answer's table: each candidate against the selected one.

    Parameters
    ----------
    decision : pandas.DataFrame
        :func:`bayesnsi.evidence.decision_table`.
    selected : str

    Returns
    -------
    pandas.DataFrame
    """
    frame = decision.copy()
    frame["probability"] = [probability_text(p) for p in frame["probability"]]
    frame["log_bayes_factor"] = [
        "—" if name == selected else _with_error(v, e) for name, v, e in
        zip(frame.index, frame["log_bayes_factor"], frame["log_bayes_factor_se"])
    ]
    frame["log_evidence"] = [_with_error(v, e, 1) for v, e in zip(frame["log_evidence"], frame["log_evidence_se"])]
    frame["strength"] = ["—" if name == selected else word for name, word in zip(frame.index, frame["strength"])]
    columns = {
        "probability": "P(model | data)",
        "log_evidence": "log evidence [nat]",
        "log_bayes_factor": f"log Bayes factor, {selected} against it [nat]",
        "strength": f"evidence for {selected}",
        "delta_log_likelihood_plain": "Δ log likelihood, paper's plain ranking [nat]",
    }
    frame = frame[[c for c in columns if c in frame.columns]].rename(columns=columns)
    return frame.rename_axis("candidate")


def ranking_frame(table):
    """Every ranking side by side, with readable headers.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`bayesnsi.evidence.ranking_table`.

    Returns
    -------
    pandas.DataFrame
    """
    out = {"prior probability": table["prior"]}
    if "log_likelihood_plain" in table:
        out["plain log likelihood [nat]"] = table["log_likelihood_plain"]
        out["plain P(model | data)"] = [probability_text(p) for p in table["p_plain"]]
    for column in table.columns:
        if column.startswith("log_evidence_") and not column.startswith("log_evidence_se_"):
            label = column.removeprefix("log_evidence_")
            name = _LIKELIHOOD.get(label, label)
            out[f"log evidence, {name} [nat]"] = [
                _with_error(v, e, 1) for v, e in zip(table[column], table[f"log_evidence_se_{label}"])
            ]
            out[f"P(model | data), {name}"] = [probability_text(p) for p in table[f"p_{label}"]]
    import pandas as pd

    return pd.DataFrame(out, index=table.index).rename_axis("candidate")


def adequacy_frame(adequacy):
    """Whiteness of each candidate's residual.

    Parameters
    ----------
    adequacy : mapping of str to Whiteness

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    return pd.DataFrame(
        {
            name: {
                "Ljung-Box p, worst channel": min(w.p_value),
                "autocorrelations outside ±1.96/√N, worst channel": max(w.fraction_outside),
                "white residual (adequate)": "yes" if w.adequate else "no",
            }
            for name, w in adequacy.items()
        }
    ).T.rename_axis("candidate")


def model_check_frame(checks):
    """Residual against the noise the model passes on, quality index and validation of each candidate.

    Parameters
    ----------
    checks : mapping of str to ModelCheck
        :func:`bayesnsi.run.adequacy.model_checks` (after any widening).

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    def row(c):
        out = {
            "residual / noise, worst channel": f"{c.noise_ratio:.3g}x",
            "near the noise (adequate)": "yes" if c.adequate else "no",
            "sensor noise from": c.noise_source,
            "worst band: residual / noise": "-" if c.band_ratio is None else (
                f"{c.band_ratio:.3g}x at {c.band_hz[0]:.3g}-{c.band_hz[1]:.3g} Hz (DOF {c.band_dof})"),
            "quality index |Im|/|Re|": "-" if c.quality_index is None else f"{c.quality_index:.3g}",
        }
        if c.validation_nrmse is not None:
            out["validation NRMSE"] = f"{c.validation_nrmse:.4g}"
        if c.widening != 1.0:
            out["intervals widened"] = f"{c.widening:.3g}x"
        return out

    return pd.DataFrame({name: row(c) for name, c in checks.items()}).T.rename_axis("candidate")


def summary_frame(summary):
    """An arviz posterior summary with readable headers.

    Parameters
    ----------
    summary : pandas.DataFrame
        Columns mean, sd, hdi95_lb, hdi95_ub, ess_bulk, ess_tail, r_hat, mcse_mean, mcse_sd.

    Returns
    -------
    pandas.DataFrame
    """
    names = {
        "mean": "mean", "sd": "sd", "hdi95_lb": "95 % HDI low", "hdi95_ub": "95 % HDI high",
        "ess_bulk": "ESS bulk", "ess_tail": "ESS tail", "r_hat": "R̂", "mcse_mean": "MC error of mean",
        "mcse_sd": "MC error of sd",
    }
    return summary.rename(columns=names).rename_axis("parameter")


def loop_frame(rows):
    """The loop's steps, in the order they were examined, with readable headers.

    Parameters
    ----------
    rows : list of dict
        ``step``, ``effect``, ``where``, ``decision``, ``reason`` and the numbers of a loop step.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    names = {
        "step": "step", "effect": "effect", "where": "where", "decision": "decision",
        "bayes_factor_log": "log Bayes factor [nat]", "coefficient": "coefficient λ",
        "ci95": "posterior 95 % about λ, given the linear part",
        "imag_ratio": "|Im|/|Re|", "halves": "λ on record halves", "nrmse_before": "NRMSE before",
        "nrmse_after": "NRMSE after", "closed_loop_nrmse_before": "closed-loop NRMSE before",
        "closed_loop_nrmse_after": "closed-loop NRMSE after", "reason": "reason",
    }
    frame = pd.DataFrame(rows)
    frame = frame[[c for c in names if c in frame.columns]].rename(columns=names).set_index("step")
    frame.attrs["wrap_last"] = True  # the reasons wrap; the numbers do not
    return frame


def _with_error(value, error, digits: int = 1) -> str:
    from ..io.report import format_number

    if value != value or error != error or abs(value) == float("inf"):  # NaN or infinite
        return format_number(value)
    shown = f"{value:,.{digits}f}" if abs(value) >= 1000 else f"{value:.{digits + 1}f}"
    return f"{shown} ± {error:.2g}"
