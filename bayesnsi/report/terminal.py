"""What the command line prints: the decision of a selection, the loop's steps and its errors before and after.

The lines say what the report and results.json say, in the same words and digits
(:mod:`bayesnsi.report.text`): the selected model with its posterior probability, the Bayes factor
against the next best in Kass and Raftery's words, its coefficients with their honest 95 %
intervals and its adequacy; for the loop, each step's decision and the errors before and after.
"""

from __future__ import annotations

import math

from ..io.units import ChannelUnits
from .loop import added_sentence, friction_sentence, hysteresis_sentences, nothing_added_note, unexamined_note
from .text import format_interval, probability_text, term_label, value_with_error

__all__ = ["diagnosis_lines", "outcome_line", "selection_lines", "step_line"]


def outcome_line(outcome, likelihood: str) -> str:
    """One line per finished candidate (a failure says why on that line).

    Parameters
    ----------
    outcome : CandidateOutcome
    likelihood : str
        The primary likelihood.

    Returns
    -------
    str
    """
    origin = "cached" if outcome.cached else f"{outcome.seconds:.1f} s"
    error = " ".join(str(outcome.error).split())  # a multi-line message on one line
    if outcome.result is None:
        return f"{outcome.name}: failed - {error} ({origin})"
    text = f"{outcome.name}: order {outcome.result.order}, NRMSE {outcome.nrmse:.4f}"
    if outcome.evidences:
        primary = outcome.evidences[likelihood]
        text += f", log Z ({primary.likelihood}) = {value_with_error(primary.log_evidence, primary.log_evidence_se)}"
    elif outcome.error is not None:
        text += f", evidence failed - {error}"
    return f"{text} ({origin})"


def selection_lines(selection, units: ChannelUnits | None = None) -> list[str]:
    """The decision of a selection, as the terminal shows it.

    Parameters
    ----------
    selection : Selection
    units : ChannelUnits, optional

    Returns
    -------
    list of str
        The selected model with its probability and the Bayes factor against the next best, its
        adequacy, then one line per coefficient with its 95 % interval.
    """
    selected, opts = selection.selected, selection.evidence
    if selected is None or opts is None or selection.table is None:
        return ["selected: none (no candidate has an evidence)"]
    from ..evidence.decision import decision_table

    decision = decision_table(selection.table, opts.likelihood, selected)
    row = decision.loc[selected]
    head = f"selected: {selected}, posterior probability {probability_text(row['probability'])}"
    others = decision.drop(index=selected)
    if len(others) and math.isfinite(others.iloc[0]["log_bayes_factor"]):
        runner = others.iloc[0]
        head += (f"; log Bayes factor {value_with_error(runner['log_bayes_factor'], runner['log_bayes_factor_se'])} "
                 f"nat over {others.index[0]} ({runner['strength']} evidence)")
    lines = [head]
    check = selection.checks.get(selected)
    if check is not None:
        word = "adequate" if check.adequate else "NOT adequate"
        lines.append(f"  {word}: open-loop residual {check.noise_ratio:.2f}x the noise it passes on "
                     f"(sensor noise from {check.noise_source})")
    lines += _coefficient_lines(selection.outcome(selected).intervals, selection.results[selected], units)
    return lines


def _coefficient_lines(intervals, result, units) -> list[str]:
    if intervals is not None and intervals.coefficients:
        return [f"  {term_label(p.name, units)} = {p.estimate:.4g}, 95 % interval {format_interval(p.ci95)}"
                for p in intervals.coefficients]
    return [f"  {term_label(c.term.name, units)} = {c.value:.4g} (|Im|/|Re| {c.imag_ratio:.2g})"
            for c in result.coefficients]


def step_line(step) -> str:
    """One line per examined effect of the loop.

    Parameters
    ----------
    step : LoopStep

    Returns
    -------
    str
    """
    return f"{'added' if step.accepted else 'rejected'} {step.term.name}: {step.reason}"


def diagnosis_lines(diagnosis, units: ChannelUnits | None = None) -> list[str]:
    """What the loop did, the final model's coefficients with intervals and the errors before and after.

    Parameters
    ----------
    diagnosis : Diagnosis
    units : ChannelUnits, optional

    Returns
    -------
    list of str
    """
    final = diagnosis.final
    lines = [added_sentence(diagnosis, units)]
    if not diagnosis.added:
        lines[0] += nothing_added_note(diagnosis) + unexamined_note(diagnosis.loop)
    if final.check is not None:
        word = "adequate" if final.check.adequate else "NOT adequate"
        lines.append(f"  final model {word}: open-loop residual {final.check.noise_ratio:.2f}x the noise it passes on")
    lines += _coefficient_lines(final.intervals, final.result, units)
    if diagnosis.loop.friction is not None:
        lines.append("  " + friction_sentence(diagnosis.loop.friction))
    signals = diagnosis.selection.signals
    if signals is not None:
        lines += ["  " + s for s in hysteresis_sentences(final.result, signals, units)]
    if signals is not None:
        try:
            before = diagnosis.loop.start.reconstruct(signals).nrmse
            after = final.result.reconstruct(signals).nrmse
            lines.append(f"  estimation data, open-loop NRMSE {before:.4g} -> {after:.4g}")
        except Exception:  # noqa: BLE001 - a model that cannot be reconstructed prints no line, the run goes on
            pass
    for b, a in zip(final.validation_before, final.validation):
        if b.nrmse is not None and a.nrmse is not None:
            what = "force-prediction" if a.quantity == "force" else "closed-loop"
            lines.append(f"  validation {b.name}: {what} NRMSE {b.nrmse:.4g} -> {a.nrmse:.4g}")
    return lines
