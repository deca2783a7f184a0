"""The report of ``bayesnsi diagnose``: what the model lacks first, then the loop step by step."""

from __future__ import annotations

from ._loop_unexamined import unexamined_note
from ._report import ANSWER, LOOP

__all__ = ["loop_sections", "loop_summary", "nothing_added_note", "step_number", "tried_with"]


def step_number(step, start) -> int:
    """The step of the loop at which ``step``'s effect was examined (1 = the first search).

    The enlarged candidate holds the starting model's terms, the effects accepted before and this
    one, so its size counts the step.

    Parameters
    ----------
    step : LoopStep
    start : NSIResult
        The loop's starting model.

    Returns
    -------
    int
    """
    return max(1, len(step.candidate.terms) - len(start.terms))


def tried_with(step, loop) -> str:
    """The terms an examined effect was tried together with that the loop never added (a look-ahead pair).

    A look-ahead examines an effect on top of one it rejected (``--lookahead``): the row of the
    second effect is counted at the next step and its errors "before" are the first effect's, so
    the table says which term it was tried with.

    Parameters
    ----------
    step : LoopStep
    loop : LoopResult

    Returns
    -------
    str
        ``" (tried with x1**3@1)"``, or "" when the effect was tried on the loop's current model.
    """
    kept = {t.name for t in loop.start.terms} | {s.term.name for s in loop.steps if s.accepted}
    extra = [t.name for t in step.candidate.terms if t.name not in kept and t.name != step.term.name]
    return f" (tried with {', '.join(extra)})" if extra else ""


def nothing_added_note(steps, payload, start_name: str) -> str:
    """What the answer adds when the loop added nothing: is the model left adequate, and why nothing fitted.

    When every effect examined was rejected by the quality index, and no other effect the loop
    re-identified (``loop_scores``) passes it, the force each would explain changes with frequency
    (docs/method.md §4), which no static term n(x, v) of the dictionary gives: the note names the
    likely causes (a nonlinearity with memory such as hysteresis, or linear dynamics the model
    lacks). When the starting model's adequacy check (``model_check``
    of its candidate record) says its residual is above the noise it passes on, the note says so, so that
    "nothing added" is not read as "nothing missing".

    Parameters
    ----------
    steps : sequence of LoopStep
        The loop's examined effects (none accepted).
    payload : dict
        The results.json payload (``candidates`` with their ``model_check``; ``loop_scores`` and
        ``settings["loop"]["max_imag_ratio"]`` when present).
    start_name : str
        The starting candidate.

    Returns
    -------
    str
        Sentences to append (with a leading space), or "" when there is nothing to add.
    """
    parts = []
    ratios = [s.imag_ratio for s in steps]
    limit = payload.get("settings", {}).get("loop", {}).get("max_imag_ratio", 0.3)
    # an effect re-identified but not examined that passes the quality index (unexamined_note names it)
    # is a dictionary term after all: then no word on memory
    passing = any(r.get("imag_ratio") is not None and r["imag_ratio"] <= limit
                  for search in payload.get("loop_scores") or () for r in search)
    if steps and all(s.reason.startswith("quality index") for s in steps) and not passing:
        parts.append(
            f"Every effect examined failed the quality index (|Im|/|Re| {min(ratios):.2g}-{max(ratios):.2g}), and "
            "so did every other effect re-identified: the force each would explain changes with frequency, which no "
            "static term n(x, v) gives - a nonlinearity with memory (hysteresis, e.g. Bouc-Wen; a dynamic joint) or "
            "linear dynamics the model lacks (a higher [nsi] order) is more likely than a missing dictionary term. "
            f"To accept the best static approximation anyway, raise [diagnose] max_imag_ratio above {min(ratios):.2g} "
            "(--max-imag-ratio)."
        )
    record = next((c for c in payload.get("candidates", ()) if c.get("name") == start_name), {})
    check = record.get("model_check") or {}
    if check and not check.get("adequate", True):
        parts.append(
            f"The model left, {start_name}, is not adequate: its residual is {check['noise_ratio']:.2f}x the noise "
            "it passes on (adequacy check in the evidence section)."
        )
    return "".join(" " + p for p in parts)


def loop_summary(loop, payload, start_name: str) -> str:
    """The line ``bayesnsi diagnose`` prints at the end: what was added and the validation error before/after.

    Parameters
    ----------
    loop : LoopResult
    payload : dict
        The results.json payload (``validation_before``, ``validation``, ``candidates``).
    start_name : str
        The starting candidate.

    Returns
    -------
    str
        E.g. ``"loop from 'linear': added x1**3@1; closed-loop validation NRMSE 0.257 -> 0.187 (second
        realisation)"``, or ``"loop from 'linear': nothing added."`` followed by :func:`nothing_added_note`.
    """
    added = [s.term.name for s in loop.steps if s.accepted]
    head = f"loop from {start_name!r}: " + (f"added {', '.join(added)}" if added else "nothing added")
    errors = [
        f"{b['nrmse']:.3g} -> {a['nrmse']:.3g} ({b['name']})"
        for b, a in zip(payload.get("validation_before", ()), payload.get("validation", ()), strict=False)
        if b.get("nrmse") is not None and a.get("nrmse") is not None
    ]
    if errors:
        head += f"; {_validation_what(payload)} NRMSE " + ", ".join(errors)
    return head + ("." if added else "." + nothing_added_note(loop.steps, payload, start_name)
                   + unexamined_note(payload))


def _adequacy_after(payload, start_name: str) -> str:
    """The final model's residual over the noise it passes on, beside the starting model's (model_check)."""
    after = (payload.get("final_model_check") or {}).get("noise_ratio")
    record = next((c for c in payload.get("candidates", ()) if c.get("name") == start_name), {})
    before = (record.get("model_check") or {}).get("noise_ratio")
    if after is None:
        return ""
    start = "" if before is None else f" ({start_name}: {before:.2f}x)"
    return f" Its open-loop residual is {after:.2f}x the noise it passes on{start}."


def _validation_what(payload) -> str:
    """What the validation errors measure: a free body's predicted force, else the closed-loop response."""
    quantities = {v.get("quantity") for v in (*payload.get("validation_before", ()), *payload.get("validation", ()))}
    return "force-prediction (free body)" if quantities == {"force"} else "closed-loop validation"


def added_channel(signals, added) -> int:
    """Output channel of the loop's overlay: where its first added effect acts (the first output otherwise)."""
    outputs, dof = list(signals.output_dofs), added[0].term.at[0]
    return outputs.index(dof) if dof in outputs else 0


def _at(effect) -> str:
    """``"at DOF 3"`` or ``"between DOFs 2 and 3"`` (:func:`_where` reads well alone, this after a name)."""
    where = _where(effect)
    return where if where.startswith("between") else f"at {where}"


def _where(effect) -> str:
    location = tuple(effect.location)
    return f"DOF {location[0]}" if len(location) == 1 else f"between DOFs {location[0]} and {location[1]}"


def loop_sections(report, signals, loop, payload, units, has_validation: bool, final_evidence=None) -> None:
    """The answer of the loop (what was added) and its section: steps in order, errors, final model, forces.

    Parameters
    ----------
    report : Report
    signals : Signals
    loop : LoopResult
    payload : dict
        The results.json payload (validation errors before/after, final coefficients).
    units : ChannelUnits
    has_validation : bool
        Whether the config has ``[[validation]]`` segments.
    final_evidence : EvidenceResult, optional
        Evidence of the final model (when the loop added an effect): its posterior comes first.
    """
    import pandas as pd

    from ..plots import plot_effect_force
    from ._report_tables import loop_frame

    added = [s for s in loop.steps if s.accepted]
    start_name = loop.start.candidate.name
    answer = report.section("Answer", ANSWER)
    if added:
        found = "; ".join(
            f"{s.effect.name} {_at(s.effect)} (λ = {s.coefficient:.4g}, "
            f"log Bayes factor {s.log_bayes_factor:.1f})"
            for s in added
        )
        final = ", ".join(t.name for t in loop.final.terms) or "linear"
        answer.append(("lead", f"Closing the loop from {start_name}: added {found}. Final model: "
                       f"{_final_values(loop, payload) or final}." + _adequacy_after(payload, start_name)))
        from ..run.residual_bands import MAX_BAND_RATIO, band_warning

        limit = payload.get("settings", {}).get("evidence", {}).get("max_band_ratio", MAX_BAND_RATIO)
        for message in band_warning(payload.get("final_model_check"), final, "the final model", limit):
            answer.append(("warning", message))
    else:
        why = (
            f"{len(loop.steps)} examined in detail; the loop table says why each was rejected" if loop.steps
            else "none came through the screen to be examined in detail; results.json loop_scores has every score"
        )
        answer.append((
            "lead", f"Closing the loop from {start_name}: nothing added - no effect examined passed the "
            f"checks ({why}).{nothing_added_note(loop.steps, payload, start_name)}{unexamined_note(payload)}",
        ))
    section = report.section("Closing the loop (docs/method.md §7)", LOOP)
    section.append(
        "Each row is an effect examined at a step, in the order of the steps (accepted first within a step). An "
        "effect is added only if its log Bayes factor (Laplace, on the residual named in the loop settings) passes "
        "the threshold, its quality index |Im|/|Re| is small and its coefficient keeps sign and size on both record "
        "halves. The posterior 95 % interval is sampled (emcee) for the effects that pass, given the linear part: "
        "it is not an uncertainty of the NSI coefficient beside it (a different estimator; it can exclude it), "
        "only the final model's intervals below are, as they include the linear part's uncertainty. NRMSE: "
        "open-loop reconstruction of the estimation data; closed-loop NRMSE: simulation of it, computed for "
        "accepted effects ('—' where the simulation diverges, e.g. chaotic responses, or was not run)."
    )
    ordered = sorted(loop.steps, key=lambda s: (step_number(s, loop.start), not s.accepted))
    if ordered:
        rows = [
            {
                "step": step_number(s, loop.start),
                "effect": s.effect.name,
                "where": _where(s.effect),
                "decision": ("added" if s.accepted else "rejected") + tried_with(s, loop),
                "bayes_factor_log": s.log_bayes_factor,
                "coefficient": s.coefficient,
                "ci95": "—" if s.ci95[0] != s.ci95[0] else f"[{s.ci95[0]:.4g}, {s.ci95[1]:.4g}]",
                "imag_ratio": s.imag_ratio,
                "halves": "—" if s.half_coefficients[0] != s.half_coefficients[0]
                else f"{s.half_coefficients[0]:.4g} / {s.half_coefficients[1]:.4g}",
                "nrmse_before": s.nrmse_before,
                "nrmse_after": s.nrmse_after,
                "closed_loop_nrmse_before": s.closed_loop_nrmse_before,
                "closed_loop_nrmse_after": s.closed_loop_nrmse_after,
                "reason": s.reason + (f"; {s.half_note}" if s.half_note else ""),
            }
            for s in ordered
        ]
        section.append(loop_frame(rows))
    if has_validation:
        section.append(
            pd.DataFrame(
                {
                    f"{_validation_what(payload)} RMSE, starting model": {
                        v["name"]: v["rmse"] for v in payload["validation_before"]},
                    f"{_validation_what(payload)} RMSE, final model": {
                        v["name"]: v["rmse"] for v in payload["validation"]},
                }
            ).rename_axis("validation segment")
        )
    else:
        section.append(
            "The config has no [[validation]] segments, so there are no errors on held-out data before and after."
        )
    if payload["final_coefficients"]:
        final_nsi = loop.settings.get("final_nsi", {})
        note = (
            f" It was re-identified with upsample = {final_nsi['upsample']} because it holds a term that switches "
            "with velocity (coefficients at the data rate are biased by the switching between samples)."
            if final_nsi.get("upsample", 1) > 1 and loop.settings.get("nsi", {}).get("upsample", 1) == 1
            else ""
        )
        section.append(
            "Coefficients of the final model (NSI estimate; quality index |Im|/|Re|). Its 95 % and 50 % intervals "
            "include the linear part's uncertainty (the identification repeated on noisy copies of the record or on "
            "records of the model, its errors-in-variables bias removed from the centre; or on record windows) + the "
            "posterior; "
            "the posterior-only interval beside them takes the linear part as exact."
            + note + _discontinuity(payload, loop)
        )
        from ._report_intervals import final_coefficients_frame

        section.append(final_coefficients_frame(payload["final_coefficients"]))
    if added:
        from ..plots import plot_reconstruction

        recs = {f"start: {start_name}": loop.start.reconstruct(signals), "final model": loop.final.reconstruct(signals)}
        at_added = added_channel(signals, added)
        name = (signals.output_names[at_added] if getattr(signals, "output_names", None)
                else f"x{signals.output_dofs[at_added]}")
        fig = plot_reconstruction(recs, signals.fs, at_added, units=units, channel_name=name)
        fig.set_label(f"Measured {name} (where the loop added its effect) against the starting and the final model "
                      "(open loop), with the errors")
        section.append(fig)
    if final_evidence is not None:
        _final_posterior(report, loop, final_evidence, units)
    for step in added:
        fig = plot_effect_force(step, signals, units=units)
        fig.set_label(
            f"Restoring-force view of {step.effect.name} {_at(step.effect)}: the residual of the model before "
            "the step as a force (top), and after it the residual (blue), the effect's force (black) and their sum "
            "(red), against displacement and velocity"
        )
        section.append(fig)


def _final_posterior(report, loop, evidence, units=None) -> None:
    """The final model's coefficient posterior, first in the posterior section."""
    from ..plots import plot_posterior_pairs, plot_traces
    from ._report import POSTERIOR
    from ._report_tables import summary_frame

    post = report.section("Coefficient posteriors", POSTERIOR)
    terms = ", ".join(t.name for t in loop.final.terms)
    post.append(f"Final model of the loop ({terms}) - log evidence {evidence.log_evidence:,.1f} ± "
                f"{evidence.log_evidence_se:.2g} nat; priors: {evidence.priors_text.replace(chr(10), '; ')}")
    post.append(summary_frame(evidence.summary))
    for message in evidence.warnings:
        post.append(("warning", message))
    if evidence.posterior.coefficients.shape[-1]:
        fig = plot_posterior_pairs(evidence.posterior, units=units)
        fig.set_label("Posterior of the coefficients, final model of the loop (arviz-plots)")
        post.append(fig)
        fig = plot_traces(evidence.posterior, units=units)
        fig.set_label("Traces of six walkers, final model of the loop (arviz-plots)")
        post.append(fig)
    post.append("The candidates of the config, as selected before the loop:")


def _discontinuity(payload, loop) -> str:
    """How the intervals of a final model with a sign() of a velocity were drawn (:mod:`bayesnsi.evidence`)."""
    from ..evidence.perturbation import discontinuity_notes
    from ._report_intervals import SURROGATE_TEXT

    intervals = payload.get("final_intervals") or {}
    if intervals.get("method") == "surrogate":
        return " " + SURROGATE_TEXT.format(names="the final model", n=intervals.get("n_segments", 0))
    if intervals.get("method") != "noise":
        return ""
    return "".join(f" {note}." for note in discontinuity_notes(loop.final))


def _final_values(loop, payload) -> str:
    """``"term = value, ..."`` of the final model, and the grid it was re-identified on when it differs from the
    steps' (its values then differ from the λ the steps quote; a trial read 0.458 in the answer, 0.367 below)."""
    records = payload.get("final_coefficients") or []
    if not records:
        return ""
    text = ", ".join(f"{r['term']} = {r['value']:.4g}" for r in records)
    upsample = (loop.settings.get("final_nsi") or {}).get("upsample", 1)
    return text + (f" (re-identified on a {upsample}x finer grid)" if upsample and upsample > 1 else "")

