"""The report of ``bayesnsi diagnose``: the final model first, then the loop step by step, then the start.

Built from a :class:`~bayesnsi.diagnosis.Diagnosis`. The answer leads with what the loop added and
where, the final model's coefficients with units and honest intervals, its natural frequencies and
damping with intervals, its adequacy (the answer's colour says adequate or not) and the errors
before and after; the selection the loop started from follows under "Before the loop".
"""

from __future__ import annotations

from ..io.units import ChannelUnits
from .answer import posterior_sections, selection_answer
from .document import Report
from .intervals import SURROGATE_TEXT, coefficient_sentence, final_coefficients_frame, mode_sentence
from .sections import ANSWER, BEFORE, LOOP
from .tables import errors_frame
from .text import format_interval, term_label

__all__ = [
    "added_channel", "added_sentence", "diagnosis_sections", "friction_sentence", "hysteresis_sentences",
    "loop_frame", "nothing_added_note", "step_number", "tried_with", "unexamined_note", "where",
]


def step_number(step, start) -> int:
    """The step of the loop at which ``step``'s effect was examined (1 = the first search).

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


def where(effect) -> str:
    """``"at DOF 3"`` or ``"between DOFs 2 and 3"``.

    Parameters
    ----------
    effect : Effect

    Returns
    -------
    str
    """
    location = tuple(effect.location)
    return f"at DOF {location[0]}" if len(location) == 1 else f"between DOFs {location[0]} and {location[1]}"


def friction_sentence(friction) -> str:
    """The physical reading of a friction law: mass, viscous coefficients by direction, Coulomb level, offset.

    Parameters
    ----------
    friction : FrictionReading
        :attr:`bayesnsi.loop.LoopResult.friction`.

    Returns
    -------
    str
    """
    parts = [(name, getattr(friction, name), friction.intervals[name], unit) for name, unit in (
        ("mass", "kg"), ("viscous_forward", "N s/m"), ("viscous_backward", "N s/m"), ("coulomb", "N"),
        ("offset", "N"))]
    words = {"mass": "mass", "viscous_forward": "viscous forwards", "viscous_backward": "viscous backwards",
             "coulomb": "Coulomb level", "offset": "offset"}
    listed = "; ".join(f"{words[n]} {v:.4g} {u} {format_interval(ci)}" for n, v, ci, u in parts)
    return (f"Friction law of the final model at DOF {friction.dof}, read in the force view with 95 % intervals: "
            f"{listed} (force-prediction rms error {friction.force_rmse:.3g} N).")


def hysteresis_sentences(result, signals, units: ChannelUnits | None = None) -> list[str]:
    """The physical reading of each Bouc-Wen term of a model: stiffness, yield and energy per cycle.

    Parameters
    ----------
    result : NSIResult
        The model (e.g. the loop's final one).
    signals : Signals
        The measured signals the terms follow (for the amplitude the loop is read at).
    units : ChannelUnits, optional
        Units of the data; "data units" when not given.

    Returns
    -------
    list of str
        One sentence per Bouc-Wen term (:func:`bayesnsi.curves.hysteresis_loop`, docs/method.md §12).
    """
    from ..curves import hysteresis_loop
    from ..exceptions import BayesNSIError

    units = units or ChannelUnits()
    stated = bool(units.force and units.displacement)
    f, x = (f" {units.force}", f" {units.displacement}") if stated else ("", "")
    stiffness_unit, energy_unit = (f" {units.force}/{units.displacement}", f" {units.force}·{units.displacement}") \
        if stated else ("", "")
    out = []
    for coefficient in result.coefficients:
        if coefficient.term.expr.memory is None:
            continue
        try:
            reading = hysteresis_loop(coefficient, signals).reading
        except BayesNSIError:
            continue
        yielding = ("it hardens on loading (no yield)" if reading.yield_displacement is None else
                    f"yield displacement {reading.yield_displacement:.3g}{x} "
                    f"(yield force {reading.yield_force:.3g}{f})")
        out.append(f"Hysteresis {term_label(coefficient.term.name, units)}: hysteretic stiffness "
                   f"{reading.stiffness:.4g}{stiffness_unit}, {yielding}; at the measured amplitude "
                   f"{reading.amplitude:.3g}{x} its loop dissipates {reading.loop_area:.3g}{energy_unit} per cycle "
                   f"(peak force {reading.peak_force:.3g}{f})" + ("." if stated else "; in the data's units."))
    return out


def added_channel(signals, added) -> int:
    """Output channel of the loop's overlay: where its first added effect acts (the first output otherwise).

    Parameters
    ----------
    signals : Signals
    added : sequence of LoopStep

    Returns
    -------
    int
    """
    outputs, dof = list(signals.output_dofs), added[0].term.at[0]
    return outputs.index(dof) if dof in outputs else 0


def added_sentence(diagnosis, units: ChannelUnits | None = None) -> str:
    """What the loop added and where, with the final model's values (and its grid when re-identified).

    Parameters
    ----------
    diagnosis : Diagnosis
    units : ChannelUnits, optional

    Returns
    -------
    str
    """
    loop = diagnosis.loop
    if not diagnosis.added:
        return f"Closing the loop from {diagnosis.start}: nothing added."
    found = "; ".join(f"{s.effect.name} {where(s.effect)} (log Bayes factor {s.log_bayes_factor:.1f})"
                      for s in diagnosis.added)
    values = ", ".join(f"{term_label(c.term.name, units)} = {c.value:.4g}" for c in loop.final.coefficients)
    upsample = loop.final_nsi.upsample
    grid = f" (re-identified on a {upsample}x finer grid)" if upsample > 1 and loop.nsi.upsample == 1 else ""
    return f"Closing the loop from {diagnosis.start}: added {found}. Final model: {values or 'linear'}{grid}."


def _adequacy_after(diagnosis) -> str:
    """The final model's residual over the noise it passes on, beside the starting model's."""
    check = diagnosis.final.check
    if check is None:
        return ""
    before = diagnosis.selection.checks.get(diagnosis.start)
    start = "" if before is None else f" ({diagnosis.start}: {before.noise_ratio:.2f}x)"
    word = "Adequate" if check.adequate else "Not adequate"
    return f" {word}: its open-loop residual is {check.noise_ratio:.2f}x the noise it passes on{start}."


def nothing_added_note(diagnosis) -> str:
    """What the answer adds when the loop added nothing: is the model left adequate, and why nothing fitted.

    When every effect examined was rejected by the quality index, and no other effect the loop
    re-identified passes it, the force each would explain changes with frequency (docs/method.md
    §4), which no static term n(x, v) gives: the note names the likely causes (a nonlinearity with
    memory such as hysteresis, or linear dynamics the model lacks). When the starting model is not
    adequate, the note says so, so that "nothing added" is not read as "nothing missing".

    Parameters
    ----------
    diagnosis : Diagnosis

    Returns
    -------
    str
        Sentences to append (with a leading space), or "".
    """
    loop, parts = diagnosis.loop, []
    steps = loop.steps
    ratios = [s.imag_ratio for s in steps]
    limit = loop.options.max_imag_ratio
    passing = any(row.imag_ratio <= limit for search in loop.scores for row in search)
    if steps and all(s.reason.startswith("quality index") for s in steps) and not passing:
        parts.append(
            f"Every effect examined failed the quality index (|Im|/|Re| {min(ratios):.2g}-{max(ratios):.2g}), and "
            "so did every other effect re-identified: the force each would explain changes with frequency, which no "
            "static term n(x, v) gives - a nonlinearity with memory (hysteresis, e.g. Bouc-Wen; a dynamic joint) or "
            "linear dynamics the model lacks (a higher [nsi] order) is more likely than a missing dictionary term. "
            f"To accept the best static approximation anyway, raise [diagnose] max_imag_ratio above {min(ratios):.2g} "
            "(--max-imag-ratio)."
        )
    check = diagnosis.selection.checks.get(diagnosis.start)
    if check is not None and not check.adequate:
        parts.append(f"The model left, {diagnosis.start}, is not adequate: its residual is {check.noise_ratio:.2f}x "
                     "the noise it passes on (adequacy check in the evidence section).")
    return "".join(" " + p for p in parts)


def unexamined_note(loop) -> str:
    """A sentence naming the effects not examined that pass the Bayes factor and the quality index.

    Parameters
    ----------
    loop : LoopResult

    Returns
    -------
    str
        With a leading space; "" when there is none (:meth:`bayesnsi.loop.LoopResult.unexamined`).
    """
    found = loop.unexamined()
    if not found:
        return ""
    names = ", ".join(f"{row.term.name} (log Bayes factor {row.log_bayes_factor:.3g}, |Im|/|Re| {row.imag_ratio:.2g})"
                      for row in found)
    n_tries = loop.options.n_tries
    return (f" Not examined: {names} - it passes the Bayes factor and the quality index, but each step examines only "
            f"the n_tries = {n_tries} effects best by evidence; rerun with --n-tries {n_tries + len(found) + 2} (or "
            "[diagnose] n_tries) to examine it.")


def loop_frame(loop, units=None):
    """The loop's steps, in the order they were examined, with readable headers.

    Parameters
    ----------
    loop : LoopResult
    units : ChannelUnits, optional

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    ordered = sorted(loop.steps, key=lambda s: (step_number(s, loop.start), not s.accepted))
    rows = [
        {
            "step": step_number(s, loop.start),
            "effect": term_label(s.term.name, units),
            "where": where(s.effect).removeprefix("at "),
            "decision": ("added" if s.accepted else "rejected") + tried_with(s, loop),
            "log Bayes factor [nat]": s.log_bayes_factor,
            "coefficient λ": s.coefficient,
            "95 % given the linear part": format_interval(s.ci95),
            "|Im|/|Re|": s.imag_ratio,
            "λ on record halves": "—" if s.half_coefficients[0] != s.half_coefficients[0]
            else f"{s.half_coefficients[0]:.4g} / {s.half_coefficients[1]:.4g}",
            "NRMSE before → after": f"{s.nrmse_before:.4g} → {s.nrmse_after:.4g}",
            "closed-loop NRMSE before → after": "—" if s.closed_loop_nrmse_after != s.closed_loop_nrmse_after
            else f"{s.closed_loop_nrmse_before:.4g} → {s.closed_loop_nrmse_after:.4g}",
            "reason": s.reason + (f"; {s.half_note}" if s.half_note else ""),
        }
        for s in ordered
    ]
    frame = pd.DataFrame(rows).set_index("step")
    frame.attrs["wrap_last"] = True  # the reasons wrap; the numbers do not
    return frame


def diagnosis_sections(report: Report, diagnosis, units: ChannelUnits) -> None:
    """The answer (the final model), the loop's section and, below, the selection it started from.

    Parameters
    ----------
    report : Report
    diagnosis : Diagnosis
    units : ChannelUnits
    """
    _answer(report, diagnosis, units)
    _loop_section(report, diagnosis, units)
    selection_answer(report, diagnosis.selection, units, "Before the loop: the selection of the config's candidates",
                     BEFORE)
    final = diagnosis.final
    evidences = {final.name: final.evidence} if final.evidence is not None and diagnosis.added else {}
    selection = diagnosis.selection
    if selection.evidence is not None:
        evidences.update({name: by[selection.evidence.likelihood] for name, by in selection.evidences.items()})
        posterior_sections(report, evidences, selection.evidence.likelihood, units)


def _answer(report: Report, diagnosis, units: ChannelUnits) -> None:
    final, loop = diagnosis.final, diagnosis.loop
    answer = report.section("Answer", ANSWER)
    lead = added_sentence(diagnosis, units)
    if diagnosis.added:
        lead += _adequacy_after(diagnosis)
    else:
        why = ("the loop table says why each examined effect was rejected" if loop.steps
               else "none came through the screen to be examined in detail; results.json loop_scores has every score")
        lead += f" No effect examined passed the checks ({why}).{nothing_added_note(diagnosis)}"
        lead += unexamined_note(loop)
    answer.append(("lead" if final.adequate in (None, True) else "lead-bad", lead))
    sentence = coefficient_sentence("the final model", final.intervals, units)
    if sentence:
        answer.append(sentence)
    if loop.friction is not None:
        answer.append(friction_sentence(loop.friction))
    if diagnosis.selection.signals is not None:
        answer.extend(hysteresis_sentences(final.result, diagnosis.selection.signals, units))
    modes = mode_sentence(final.intervals)
    answer.append(modes or "Natural frequencies and damping ratios of the final model: "
                  + "; ".join(f"{m.frequency_hz:.4g} Hz, ζ {100 * m.damping_ratio:.3g} %" for m in final.result.modes)
                  + ".")
    errors = errors_frame(diagnosis)
    if errors is not None:
        answer.append("Errors of the starting model and of the final model (NRMSE; validation: closed-loop simulation "
                      "of held-out data, never used for a decision):")
        answer.append(errors)
    for finding in diagnosis.findings:
        answer.append(("warning", finding.message))
    if report.figures:
        _final_frf(answer, diagnosis, units)


def _final_frf(answer: list, diagnosis, units: ChannelUnits) -> None:
    """The final model's underlying FRF beside the starting model's and the data's."""
    import numpy as np

    from ..plots import plot_frf
    from .choices import frf_band

    signals = diagnosis.selection.signals
    models = {f"start: {diagnosis.start}": diagnosis.loop.start, "final model": diagnosis.final.result}
    fmax, measured, wide = frf_band(signals, models)
    freqs = np.geomspace(fmax / 400, fmax, 600) if wide else np.linspace(fmax / 400, fmax, 600)
    fig = plot_frf(list(models.values()), freqs, units=units, measured=measured, log_frequency=wide,
                   labels=list(models))
    fig.set_label("Underlying linear FRF of the final model beside the starting model's and the data's own FRF "
                  "(grey, H1, where its coherence is at least 0.5)")
    answer.append(fig)


def _loop_section(report: Report, diagnosis, units: ChannelUnits) -> None:
    loop, final = diagnosis.loop, diagnosis.final
    signals = diagnosis.selection.signals
    section = report.section("Closing the loop (docs/method.md §7)", LOOP)
    section.append(
        "Each row is an effect examined at a step, in the order of the steps (accepted first within a step). An "
        "effect is added only if its log Bayes factor (Laplace, on the residual named in the loop settings) passes "
        "the threshold, its quality index |Im|/|Re| is small and its coefficient keeps sign and size on both record "
        "halves. The posterior 95 % interval of a step is given the linear part and moved onto the step's NSI "
        "coefficient; only the final model's intervals include the linear part's uncertainty. NRMSE: open-loop "
        "reconstruction of the estimation data; closed-loop NRMSE: its simulation, for accepted effects ('—' where "
        "the simulation diverges or was not run)."
    )
    if loop.steps:
        section.append(loop_frame(loop, units))
    if final.result.coefficients:
        note = (f" It was re-identified with upsample = {loop.final_nsi.upsample} because it holds a term that "
                "switches with velocity (coefficients at the data rate are biased by the switching between samples)."
                if loop.final_nsi.upsample > 1 and loop.nsi.upsample == 1 else "")
        section.append("Coefficients of the final model (NSI estimate; quality index |Im|/|Re|) with their 95 % and "
                       "50 % intervals, the linear part's uncertainty included; the interval given the linear part "
                       "beside them takes it as exact." + note + _interval_how(final))
        section.append(final_coefficients_frame(final, units))
    if diagnosis.added and report.figures:
        _loop_figures(section, diagnosis, signals, units)


def _interval_how(final) -> str:
    """How the final model's intervals were drawn, when by model replicates or with discontinuous terms."""
    intervals = final.intervals
    if intervals is None:
        return ""
    if intervals.method == "surrogate":
        return " " + SURROGATE_TEXT.format(names="the final model", n=intervals.n_segments)
    return "".join(f" {f.message}." for f in intervals.findings if f.kind == "interval.discontinuous")


def _loop_figures(section: list, diagnosis, signals, units: ChannelUnits) -> None:
    from ..plots import plot_effect_force, plot_hysteresis_loop, plot_reconstruction

    added = diagnosis.added
    channel = added_channel(signals, added)
    recs = {f"start: {diagnosis.start}": diagnosis.loop.start.reconstruct(signals),
            "final model": diagnosis.final.result.reconstruct(signals)}
    name = signals.output_names[channel]
    fig = plot_reconstruction(recs, signals.fs, channel, units=units, channel_name=name)
    fig.set_label(f"Measured {name} (where the loop added its first effect) against the starting and the final model "
                  "(open loop), with the errors")
    section.append(fig)
    for step in added:
        fig = plot_effect_force(step, signals, units=units)
        fig.set_label(f"Restoring-force view of {step.effect.name} {where(step.effect)}: the residual of the model "
                      "before the step as a force (top), and after it the residual (blue), the effect's force (black) "
                      "and their sum (red), against displacement and velocity")
        section.append(fig)
        if step.term.expr.memory is not None:
            fig = plot_hysteresis_loop(step, signals, units=units)
            fig.set_label(f"Restoring-force loop of {step.effect.name} {where(step.effect)}: λ z against the "
                          "displacement it follows, on the record (grey) and in periodic steady state at the measured "
                          "amplitude (black)")
            section.append(fig)
