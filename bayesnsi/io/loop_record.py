"""results.json of ``bayesnsi diagnose`` (docs/method.md §9): built from a :class:`~bayesnsi.diagnosis.Diagnosis`.

The selection's record (:func:`bayesnsi.io.selection_payload`) with the loop added: ``start``,
``loop`` (accepted steps) and ``loop_rejected``, each step with its effect, decision, reason,
coefficient, Bayes factor, quality index and errors before and after; ``loop_scores`` (every effect
of every search); the final model (``final_model``, ``final_coefficients`` with their honest
intervals, ``final_intervals``, ``final_evidence``, ``final_model_check``); and the closed-loop
errors of the starting and the final model on each validation segment (``validation_before``,
``validation``), and the physical reading of a friction law the final model holds (``friction``).
"""

from __future__ import annotations

from typing import Any

from .results import to_jsonable
from .schema import selection_payload, term_record

__all__ = ["diagnosis_payload", "step_record"]


def step_record(step, loop) -> dict[str, Any]:
    """One examined effect of the loop as results.json holds it.

    Parameters
    ----------
    step : LoopStep
    loop : LoopResult
        The loop it belongs to (for the effects its search screened and scored).

    Returns
    -------
    dict
    """
    effect = step.effect
    record: dict[str, Any] = {"type": effect.base, "at": list(effect.location), "gap": effect.gap}
    if effect.eps is not None:  # a tanh(v/eps) friction's width
        record["eps"] = effect.eps
    if effect.shape is not None:  # a Bouc-Wen element's shape (also written in its term)
        record["shape"] = {"beta": effect.shape.beta, "gamma": effect.shape.gamma, "n": effect.shape.n}
    return {
        "added": term_record(step.term),
        "effect_type": effect.name,
        "effect": record,
        "accepted": step.accepted,
        "reason": step.reason,
        "coefficient": step.coefficient,
        "ci95_given_linear_part": list(step.ci95),
        "imag_ratio": step.imag_ratio,
        "half_coefficients": list(step.half_coefficients),
        "half_block_rows": step.half_block_rows,
        "half_note": step.half_note,
        "bayes_factor_log": step.log_bayes_factor,
        "nrmse_before": step.nrmse_before,
        "nrmse_after": step.nrmse_after,
        "closed_loop_nrmse_before": step.closed_loop_nrmse_before,
        "closed_loop_nrmse_after": step.closed_loop_nrmse_after,
        "error_quantity": step.error_quantity,
        "short_horizon_nrmse_before": step.short_horizon_nrmse_before,
        "short_horizon_nrmse_after": step.short_horizon_nrmse_after,
        "checks": [{"name": c.name, "value": c.value, "limit": c.limit, "passed": c.passed, "text": c.text}
                   for c in step.checks],
        "quality_only": step.quality_only,
        "index_unresolved": step.index_unresolved,
        "misfit_ratio": step.misfit_ratio,
        "memory_resolution": step.memory_resolution,
        "search": step.search,  # the effects that search screened and scored, what became of each
        "screened": [] if step.search is None else loop.search_records(step.search),
    }


def _final_coefficients(final) -> list[dict[str, Any]]:
    """The final coefficients: NSI value, quality index, honest ``ci95``/``ci50``/``sd`` (``interval`` says how;
    centred on ``estimate``, the NSI value), ``posterior_mean`` and ``ci95_given_linear_part``."""
    posterior = [] if final.evidence is None else list(final.evidence.ci95)
    records = []
    for k, c in enumerate(final.result.coefficients):
        record: dict[str, Any] = {"term": c.term.name, "value": c.value, "imag_ratio": c.imag_ratio}
        if final.intervals is not None and k < len(final.intervals.coefficients):
            iv = final.intervals.coefficients[k]
            record.update(estimate=iv.estimate, ci95=list(iv.ci95), ci50=list(iv.ci50), sd=iv.sd,
                          interval=final.intervals.method, posterior_mean=iv.posterior_mean, bias=iv.bias)
        if k < len(posterior):
            record["ci95_given_linear_part"] = [float(posterior[k][0]), float(posterior[k][1])]
        records.append(record)
    return records


def diagnosis_payload(diagnosis, command: str, config, data_findings=()) -> dict[str, Any]:
    """results.json of a diagnosis (``bayesnsi diagnose``).

    Parameters
    ----------
    diagnosis : Diagnosis
    command : str
        The command that ran.
    config : ExperimentConfig
        The config it ran.
    data_findings : sequence of Finding
        What loading the data found.

    Returns
    -------
    dict
        JSON-ready (module notes); ``selected`` stays the ranking's choice (``start`` is not a selection).
    """
    loop, final = diagnosis.loop, diagnosis.final
    steps = [step_record(s, loop) for s in loop.steps]
    payload = selection_payload(
        diagnosis.selection, command, config, data_findings,
        start=diagnosis.start,
        final_model=[term_record(t) for t in final.result.terms],
        final_coefficients=_final_coefficients(final),
        final_modes=[{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio} for m in final.result.modes],
        loop=[s for s, step in zip(steps, loop.steps) if step.accepted],
        loop_rejected=[s for s, step in zip(steps, loop.steps) if not step.accepted],
        validation_before=[e.to_dict() for e in final.validation_before],
        validation=[e.to_dict() for e in final.validation],
        loop_scores=[loop.search_records(k) for k in range(len(loop.scores))],
        loop_findings=[f.to_dict() for f in diagnosis.findings],
        friction=None if loop.friction is None else loop.friction.as_dict(),
    )
    payload["settings"]["loop"] = {**loop.options.to_dict(), "final_nsi": loop.final_nsi.to_dict(),
                                   "nsi": loop.nsi.to_dict(), "n_effects": loop.n_effects}
    if final.intervals is not None:  # as select's "intervals": coefficients and modes, method, windows
        payload["final_intervals"] = to_jsonable(final.intervals.to_dict())
    if final.check is not None:  # the final model's adequacy, as select's model_check of a candidate
        payload["final_model_check"] = to_jsonable(final.check.to_dict())
    if final.evidence is not None and diagnosis.added:
        payload["final_evidence"] = to_jsonable(final.evidence.to_dict())
    return to_jsonable(payload)
