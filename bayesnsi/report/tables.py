"""Tables of the report with readable headers: the library's results arranged and worded, nothing computed."""

from __future__ import annotations

from .text import probability_text, value_with_error

__all__ = [
    "adequacy_frame", "decision_frame", "errors_frame", "model_check_frame", "ranking_frame",
    "summary_frame",
]

_LIKELIHOOD = {"white": "white", "ar1": "AR(1)", "arP": "AR(P)"}


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
        "—" if name == selected else value_with_error(v, e) for name, v, e in
        zip(frame.index, frame["log_bayes_factor"], frame["log_bayes_factor_se"])
    ]
    frame["log_evidence"] = [value_with_error(v, e) for v, e in zip(frame["log_evidence"], frame["log_evidence_se"])]
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
                value_with_error(v, e) for v, e in zip(table[column], table[f"log_evidence_se_{label}"])
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
        :func:`bayesnsi.checks.adequacy.model_checks` (after any widening).

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    def row(c):
        out = {
            "residual / noise, worst channel": f"{c.noise_ratio:.2f}x",
            "near the noise (adequate)": "yes" if c.adequate else "no",
            "sensor noise from": c.noise_source,
            "worst band: residual / noise": "-" if c.band_ratio is None else (
                f"{c.band_ratio:.2f}x at {c.band_hz[0]:.3g}-{c.band_hz[1]:.3g} Hz (DOF {c.band_dof})"),
            "quality index |Im|/|Re|": "-" if c.quality_index is None else f"{c.quality_index:.3g}",
        }
        if c.validation_nrmse is not None:
            out["validation NRMSE"] = f"{c.validation_nrmse:.4g}"
        if c.widening != 1.0:
            out["intervals widened"] = f"{c.widening:.2f}x"
        return out

    return pd.DataFrame({name: row(c) for name, c in checks.items()}).T.rename_axis("candidate")


def summary_frame(summary):
    """An arviz posterior summary (given the identified linear part) with readable headers.

    Parameters
    ----------
    summary : pandas.DataFrame
        Columns mean, sd, hdi95_lb, hdi95_ub, ess_bulk, ess_tail, r_hat, mcse_mean, mcse_sd.

    Returns
    -------
    pandas.DataFrame
    """
    names = {
        "mean": "mean", "sd": "sd", "hdi95_lb": "95 % HDI given the linear part, low",
        "hdi95_ub": "95 % HDI given the linear part, high", "ess_bulk": "ESS bulk", "ess_tail": "ESS tail",
        "r_hat": "R̂", "mcse_mean": "MC error of mean", "mcse_sd": "MC error of sd",
    }
    return summary.rename(columns=names).rename_axis("parameter")


def errors_frame(diagnosis):
    """Errors of the starting and the final model: open loop on the estimation data, each validation segment.

    Parameters
    ----------
    diagnosis : Diagnosis

    Returns
    -------
    pandas.DataFrame or None
        Rows: "estimation data (open loop)" and each validation segment; columns before and after,
        NRMSE (and RMSE in the measured quantity for the segments).
    """
    import pandas as pd

    loop, final = diagnosis.loop, diagnosis.final
    rows = {}
    signals = diagnosis.selection.signals
    if signals is not None:
        try:
            rows["estimation data (open loop)"] = {
                "before (NRMSE)": float(loop.start.reconstruct(signals).nrmse),
                "after (NRMSE)": float(final.result.reconstruct(signals).nrmse)}
        except Exception:  # noqa: BLE001 - a model that cannot be reconstructed shows no row, the report goes on
            pass
    for before, after in zip(final.validation_before, final.validation):
        what = " (force prediction)" if after.quantity == "force" else ""
        rows[f"validation {before.name}{what}"] = {"before (NRMSE)": before.nrmse, "after (NRMSE)": after.nrmse,
                                                  "before (RMSE)": before.rmse, "after (RMSE)": after.rmse}
    if not rows:
        return None
    return pd.DataFrame(rows).T.rename_axis("data")
