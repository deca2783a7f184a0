"""results.json records (docs/method.md §9): plain dicts built from the library's typed result objects.

Field names listed in docs/method.md §9 are stable; further fields are additions. Every record of a run is
assembled here, from a :class:`bayesnsi.selection.Selection` or a list of
:class:`bayesnsi.run.CandidateOutcome`, so the commands and workflows write the same shape.
"""

from __future__ import annotations

import math
from typing import Any

from ..findings import messages
from ..models import Term
from .results import to_jsonable, versions

__all__ = ["term_record", "candidate_record", "identification_payload", "intervals_record", "selection_payload"]


def term_record(term: Term) -> dict[str, Any]:
    """``{expr, at}`` of a term, ``at`` an int or a pair as in the config.

    Parameters
    ----------
    term : Term

    Returns
    -------
    dict
    """
    return {"expr": term.expr.text, "at": term.at_value}


def candidate_record(outcome, row=None, likelihood: str | None = None) -> dict[str, Any]:
    """Record of one candidate: identification, errors and, with a ranking row, its evidence.

    Parameters
    ----------
    outcome : CandidateOutcome
        What the candidate gave (:func:`bayesnsi.run.run_candidates`).
    row : pandas.Series, optional
        Its row of the ranking table (:attr:`bayesnsi.selection.Selection.table`).
    likelihood : str, optional
        The likelihood whose evidence selects (``EvidenceOptions.likelihood``).

    Returns
    -------
    dict
        ``status`` is ``ok``, ``failed`` (no model: ``error``) or ``evidence_failed`` (a model but
        no evidence: ``error``); an internal error adds ``internal_error`` and ``traceback``.
    """
    candidate, result = outcome.candidate, outcome.result
    record: dict[str, Any] = {
        "name": candidate.name,
        "status": outcome.status,
        "prior": candidate.prior,
        "terms": [term_record(t) for t in candidate.terms],
        "coefficients": [],
        "modes": [],
        "nrmse": outcome.nrmse,
    }
    if outcome.error is not None:
        prefix = {"evidence": "evidence: ", "internal": "internal error: "}.get(outcome.failed_stage, "")
        record["error"] = prefix + outcome.error
    if outcome.failed_stage == "internal":
        record.update(internal_error=True, traceback=outcome.traceback)
    if result is not None:
        record.update(_identification(result))
        record["nrmse_per_channel"] = list(outcome.nrmse_per_channel)
    if row is not None:
        record.update(_evidence(outcome, row, likelihood))
    record.update(findings=[f.to_dict() for f in outcome.findings], warnings=list(messages(outcome.findings)),
                  seconds=outcome.seconds, cached=outcome.cached)
    return record


def _identification(result) -> dict[str, Any]:
    return {
        "terms": [term_record(t) for t in result.terms],
        "coefficients": [
            {**term_record(c.term), "value": c.value, "imag_ratio": c.imag_ratio, "spread": c.spread,
             "excluded_fraction": c.excluded_fraction, "ci95": None}
            for c in result.coefficients
        ],
        "modes": [{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio} for m in result.modes],
        "spurious_poles": [{"real": p.real, "imag": p.imag} for p in result.spurious_poles],
        # free bodies: rigid-body poles (s ≈ 0) and the known spring used while identifying
        "rigid_body_poles": [{"real": p.real, "imag": p.imag} for p in result.rigid_body_poles],
        "virtual_stiffness": result.virtual_stiffness,
        "physical_parameters": [
            {"dof": p.dof, "mass": p.mass, "damping": p.damping, "stiffness": p.stiffness, "band_hz": list(p.band_hz)}
            for p in result.physical_parameters
        ],
        "order": result.order,
        "block_rows": result.block_rows,
        "band_hz": list(result.band_hz),
        "singular_values": [float(s) for s in result.singular_values[: 2 * result.order + 10]],
        # frequency route: fitted lines, noise-weighted misfit on them (≈ 1: down to the noise), reflected poles
        "periodic": None if result.options.domain != "frequency" else {
            k: result.settings[k] for k in ("domain", "fit_band_hz", "n_lines", "n_periods", "period",
                                            "requested_block_rows", "n_realisations", "line_misfit",
                                            "unexcited_ratio", "reflected_poles_hz")},
        "settings": result.settings,
    }


def _evidence(outcome, row, likelihood) -> dict[str, Any]:
    out: dict[str, Any] = {
        "log_likelihood_gaussian": _finite(row["log_likelihood_plain"]),
        "posterior_gaussian": float(row["p_plain"]),
    }
    evidences = outcome.evidences
    if evidences is None:
        out.update(log_evidence=None, log_evidence_se=None, posterior=0.0, rhat_max=None, ess_min=None)
        return out
    primary = evidences[likelihood]
    out.update(
        log_evidence=primary.log_evidence,
        log_evidence_se=primary.log_evidence_se,
        log_evidence_laplace=primary.laplace_log_evidence,  # an approximation: its error beside it
        log_evidence_laplace_error=_finite(primary.laplace_error),
        log_evidence_closed_form=primary.closed_form_log_evidence,
        log_evidence_exact=primary.exact_log_evidence,
        posterior=float(row[f"p_{likelihood}"]),
        posterior_sd=float(row[f"p_{likelihood}_sd"]),
        rhat_max=primary.rhat_max,
        ess_min=primary.ess_min,
        likelihood=likelihood,
        sampler=None if primary.sampler is None else primary.sampler.to_dict(),
        evidence_by_likelihood={
            name: {
                "log_evidence": e.log_evidence,
                "log_evidence_se": e.log_evidence_se,
                "posterior": float(row[f"p_{name}"]),
            }
            for name, e in evidences.items()
        },
    )
    if outcome.result is not None:
        out.update(_intervals(outcome, primary))
    return out


def _intervals(outcome, primary) -> dict[str, Any]:
    """Coefficients and modes with their intervals: ``ci95``/``ci50`` the honest ones
    (:attr:`CandidateOutcome.intervals`; None where there are none), ``ci95_given_linear_part`` the
    posterior's given the identified linear part."""
    return intervals_record(_identification(outcome.result), outcome.intervals, primary)


def intervals_record(identified: dict[str, Any], intervals, evidence) -> dict[str, Any]:
    """Coefficient and mode records with their intervals (one meaning of ``ci95`` on every surface).

    Parameters
    ----------
    identified : dict
        The identification's record (``coefficients`` and ``modes``).
    intervals : Intervals or None
        The honest intervals (:func:`bayesnsi.uncertainty.candidate_intervals`).
    evidence : EvidenceResult or None
        The posterior given the identified linear part.

    Returns
    -------
    dict
        ``coefficients`` (``ci95``, ``ci50``, ``sd``, ``interval`` method, ``posterior_mean``, ``bias``,
        ``ci95_given_linear_part``), ``modes`` with their intervals, and ``intervals`` (the whole record).
    """
    coefficients = []
    posterior = [] if evidence is None else list(evidence.ci95)
    for k, coefficient in enumerate(identified["coefficients"]):
        record = {**coefficient, "ci95": None}
        if k < len(posterior):
            record["ci95_given_linear_part"] = [float(posterior[k][0]), float(posterior[k][1])]
        if intervals is not None and k < len(intervals.coefficients):
            iv = intervals.coefficients[k]
            record.update(ci95=list(iv.ci95), ci50=list(iv.ci50), sd=iv.sd, interval=intervals.method,
                          estimate=iv.estimate, posterior_mean=iv.posterior_mean, bias=iv.bias)
        coefficients.append(record)
    out: dict[str, Any] = {"coefficients": coefficients}
    if intervals is not None and intervals.frequencies:
        out["modes"] = [
            {**mode, "frequency_ci95": list(f.ci95), "frequency_ci50": list(f.ci50), "frequency_sd": f.sd,
             "damping_ci95": list(z.ci95), "damping_ci50": list(z.ci50), "damping_sd": z.sd}
            for mode, f, z in zip(identified["modes"], intervals.frequencies, intervals.damping_ratios)
        ]
    if intervals is not None:
        out["intervals"] = intervals.to_dict()
    return out


def identification_payload(outcomes, command: str, config, data_findings=()) -> dict[str, Any]:
    """results.json of a run without evidence (``bayesnsi identify``).

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
        One per candidate.
    command : str
        The command that ran.
    config : ExperimentConfig
        The config it ran (its path, raw tables and settings are recorded).
    data_findings : sequence of Finding
        What loading the data found.

    Returns
    -------
    dict
        JSON-ready.
    """
    payload = {
        "command": command,
        "config": str(config.path),
        "selected": None,
        "candidates": [candidate_record(o) for o in outcomes],
        "data_findings": [f.to_dict() for f in data_findings],
        "data_warnings": list(messages(data_findings)),  # the findings' sentences (stable name)
        "settings": _settings(config, evidence=None),
        "versions": versions(),
    }
    return to_jsonable(payload)


def selection_payload(selection, command: str, config, data_findings=(), **extra) -> dict[str, Any]:
    """results.json of a selection (``bayesnsi select``, ``demo``, ``diagnose``).

    Parameters
    ----------
    selection : Selection
        What :func:`bayesnsi.selection.select` returned.
    command : str
        The command that ran.
    config : ExperimentConfig
        The config it ran.
    data_findings : sequence of Finding
        What loading the data found (``data_findings``).
    **extra
        Further top-level fields (e.g. the loop of ``diagnose``).

    Returns
    -------
    dict
        JSON-ready: ``selected`` (marginal evidence), ``selected_gaussian`` (plain likelihood),
        ``plausible`` (the most probable candidate that passes the physical checks,
        :attr:`Selection.plausible <bayesnsi.selection.Selection.plausible>`), ``candidates`` with
        evidence and validation, ``ranking``, ``comparison`` (:meth:`Selection.comparison`), ``findings``,
        ``data_findings``, ``settings``, ``versions``.
    """
    likelihood = selection.likelihood
    records = []
    for outcome in selection.outcomes:
        row = None if selection.table is None else selection.table.loc[outcome.name]
        record = candidate_record(outcome, row, likelihood)
        if outcome.name in selection.validation:
            record["validation"] = [e.to_dict() for e in selection.validation[outcome.name]]
        if outcome.name in selection.adequacy:
            record["adequacy"] = selection.adequacy[outcome.name].to_dict()
        if outcome.name in selection.checks:
            record["model_check"] = selection.checks[outcome.name].to_dict()
        if outcome.name in selection.open_loop:
            record["open_loop"] = selection.open_loop[outcome.name].to_dict()
        records.append(record)
    selected = selection.selected
    payload = {
        "command": command,
        "config": str(config.path),
        "selected": selected,
        "selected_gaussian": selection.selected_gaussian,
        "plausible": selection.plausible,
        "likelihood": likelihood,
        "candidates": records,
        "validation": [e.to_dict() for e in selection.validation.get(selected, ())] if selected else [],
        "ranking": [] if selection.table is None else selection.table.reset_index().to_dict(orient="records"),
        "comparison": _comparison(selection),
        "findings": [f.to_dict() for f in selection.findings],
        "warnings": list(messages(selection.findings)),  # their sentences (stable name)
        "data_findings": [f.to_dict() for f in data_findings],
        "data_warnings": list(messages(data_findings)),
        "settings": _settings(config, selection.evidence),
        "versions": versions(),
        **extra,
    }
    return to_jsonable(payload)


def _comparison(selection) -> list[dict[str, Any]]:
    """:meth:`Selection.comparison` as records (empty when no candidate has an evidence)."""
    table, likelihood = selection.table, selection.likelihood
    if table is None or likelihood is None or f"log_evidence_{likelihood}" not in table:
        return []
    return selection.comparison().reset_index().to_dict(orient="records")


def _settings(config, evidence) -> dict[str, Any]:
    settings = {"config": config.raw, "seed": config.seed, "nsi": config.nsi.to_dict()}
    if evidence is not None:
        settings["evidence"] = evidence.to_dict()
    return settings


def _finite(value):
    value = float(value)
    return value if math.isfinite(value) else None
