"""The answer of a selection: which model, how sure, how well - then the evidence, adequacy and posteriors.

Built from a :class:`~bayesnsi.selection.Selection`. The answer leads with the selected model, its
posterior probability and the Bayes factor against the next best in words, its coefficients with
their honest 95 % intervals (the linear part's uncertainty included), its natural frequencies and
damping with intervals, and its adequacy, the colour of the answer saying whether it explains the
data. The coefficient posteriors given the identified linear part are shown under their own name.
"""

from __future__ import annotations

import numpy as np

from ..checks.validation import whiteness_applies
from ..io.units import ChannelUnits
from .choices import plausible_text
from .document import Report
from .intervals import coefficient_sentence, interval_sections, mode_sentence
from .sections import ANSWER, EVIDENCE, POSTERIOR
from .tables import adequacy_frame, decision_frame, model_check_frame, ranking_frame, summary_frame
from .text import probability_text, value_with_error

__all__ = ["RESIDUAL_TEXT", "LIKELIHOOD_TEXT", "answer_lead", "evidence_sections", "posterior_sections",
           "selection_answer"]

RESIDUAL_TEXT = {
    "reconstruction": "open-loop reconstruction residual",
    "innovations": "one-step-ahead innovations of the Kalman predictor that carries the input noise",
}
LIKELIHOOD_TEXT = {"white": "white Gaussian", "ar1": "AR(1) Gaussian", "arP": "AR(P) Gaussian"}


def answer_lead(decision, selected: str, likelihood: str, role: str = "Selected") -> str:
    """The answer's first sentences: the model, its probability, the Bayes factor against the next best.

    Parameters
    ----------
    decision : pandas.DataFrame
        :func:`bayesnsi.evidence.decision_table`.
    selected : str
    likelihood : str
    role : str
        How the sentence names the model.

    Returns
    -------
    str
    """
    row = decision.loc[selected]
    text = (f"{role}: {selected}, posterior probability {probability_text(row['probability'])} "
            f"(evidence with {LIKELIHOOD_TEXT.get(likelihood, likelihood)} residuals).")
    others = decision.drop(index=selected)
    if len(others):
        runner, bf = others.index[0], others.iloc[0]
        if np.isfinite(bf["log_bayes_factor"]):
            text += (f" Against the next best, {runner}: log Bayes factor "
                     f"{value_with_error(bf['log_bayes_factor'], bf['log_bayes_factor_se'])} nat ({bf['strength']}).")
        else:
            text += f" Every other candidate failed ({runner} first)."
    return text


def selection_answer(report: Report, selection, units: ChannelUnits, heading: str = "Answer",
                     order: int = ANSWER) -> None:
    """The answer of a selection: decision, coefficients and modes with intervals, adequacy, findings.

    Parameters
    ----------
    report : Report
    selection : Selection
    units : ChannelUnits
    heading : str
        The section (``diagnose`` puts the selection under "Before the loop").
    order : int
        Its place.
    """
    selected, table, opts = selection.selected, selection.table, selection.evidence
    answer = report.section(heading, order)
    if table is None or selected is None or opts is None or f"log_evidence_{opts.likelihood}" not in table:
        answer.append(("warning", "No candidate has an evidence: there is no selection to report."))
        _findings(answer, selection)
        return
    from ..evidence.decision import decision_table

    decision = decision_table(table, opts.likelihood, selected)
    check = selection.checks.get(selected)
    none_adequate = bool(selection.checks) and not any(c.adequate for c in selection.checks.values())
    lead = answer_lead(decision, selected, opts.likelihood) + _adequacy_sentence(check, none_adequate)
    lead += plausible_text(selection, selected, decision)
    answer.append(("lead" if check is None or check.adequate else "lead-bad", lead))
    outcome = selection.outcome(selected)
    if outcome.intervals is not None:
        sentence = coefficient_sentence(selected, outcome.intervals, units)
        if sentence:
            answer.append(sentence)
        modes = mode_sentence(outcome.intervals)
        if modes:
            answer.append(modes)
    answer.append(decision_frame(decision, selected))
    residual = RESIDUAL_TEXT.get(opts.residual, opts.residual)
    answer.append(
        f"Evidence: marginal likelihood of each candidate, the {residual} modelled as "
        f"{LIKELIHOOD_TEXT.get(opts.likelihood, opts.likelihood)} noise (coefficients and noise level integrated over "
        "proper priors; the coefficients sampled by emcee, the evidence by bridge sampling; docs/method.md §6). The "
        "log "
        "Bayes factor is the difference of log evidences [nat]; the words are Kass and Raftery's (1 nat: barely worth "
        "mentioning, 3: strong, 5: very strong). ± are Monte-Carlo errors."
    )
    _findings(answer, selection)
    if len(decision) > 1 and report.figures:
        from ..plots import plot_bayes_factors

        fig = plot_bayes_factors(decision, selected)
        fig.set_label("Log Bayes factor of the selected model against each other candidate (±2 Monte-Carlo "
                      "standard errors; symmetric-log axis beyond 10 nat), over Kass and Raftery's bands")
        answer.append(fig)


def _adequacy_sentence(check, none_adequate: bool) -> str:
    if check is None:
        return ""
    if none_adequate:
        return (f" Not adequate: its residual is {check.noise_ratio:.2f}x the noise it passes on, and no candidate "
                "explains the data down to the noise, so the probability says which is least wrong, not that it is "
                "right.")
    if not check.adequate:
        return f" Not adequate: its residual is {check.noise_ratio:.2f}x the noise it passes on."
    return f" Adequate: its residual is {check.noise_ratio:.2f}x the noise it passes on."


def _findings(answer: list, selection) -> None:
    selected = selection.selected
    whiteness = selection.adequacy.get(selected) if selected else None
    if whiteness is not None and not whiteness.adequate:
        answer.append(("warning", f"The selected model's {whiteness.residual} residual is not white (Ljung-Box p = "
                                  f"{min(whiteness.p_value):.2g}): an effect may be missing from every candidate; "
                                  "`bayesnsi diagnose` searches for it."))
    for finding in selection.findings:
        answer.append(("warning" if finding.severity == "warning" else "note", finding.message))
    for outcome in selection.outcomes:
        if outcome.error is not None:
            answer.append(("warning", f"{outcome.name}: {outcome.failed_stage or 'run'} failed - {outcome.error}"))


def evidence_sections(report: Report, selection, units: ChannelUnits) -> None:
    """Every candidate's evidence, the plain ranking beside it, adequacy, the model checks, intervals.

    Parameters
    ----------
    report : Report
    selection : Selection
    units : ChannelUnits
    """
    opts, signals = selection.evidence, selection.signals
    evidence = report.section("Evidence and adequacy of every candidate (paper Eqs. 1-4)", EVIDENCE)
    if selection.table is not None:
        evidence.append(
            "The paper's plain ranking uses a Gaussian likelihood of the open-loop reconstruction residual with "
            "σ̂² set to each model's own mean squared residual; with thousands of samples it gives 0 or 1 and "
            "favours the largest model. The evidence columns integrate over the coefficients instead."
        )
        evidence.append(ranking_frame(selection.table))
    residual = RESIDUAL_TEXT.get(opts.residual, opts.residual) if opts is not None else "residual"
    if selection.adequacy:
        evidence.append(f"Adequacy: a Ljung-Box test of each candidate's {residual} asks whether the model explains "
                        "the data (a white residual). The probabilities only compare the candidates with each other.")
        evidence.append(adequacy_frame(selection.adequacy))
    elif selection.checks and signals is not None and not whiteness_applies(signals):
        source = {"acceleration": "accelerations", "velocity": "velocities"}.get(signals.measured, signals.measured)
        evidence.append(f"Adequacy: no whiteness test - the responses were integrated from {source}, whose noise the "
                        "integration colours, so no model's residual is white; the residual against that integrated "
                        "noise (below) says whether a model explains the data.")
    if selection.checks:
        evidence.append(
            "Model check: each candidate's open-loop residual rms over the noise it passes on - the change of its "
            "residual when fresh sensor noise is added to the data (a model that explains the data leaves about 1x; "
            "above max_noise_ratio it is not adequate and its intervals are widened by the ratio) - the same band by "
            "band, the quality index of its coefficients and, with validation data, its closed-loop error."
        )
        evidence.append(model_check_frame(selection.checks))
        check = selection.checks.get(selection.selected)
        if check is not None and check.band_ratios and report.figures and opts is not None:
            from ..plots import plot_band_ratios

            fig = plot_band_ratios(check, list(signals.output_names), opts.max_band_ratio)
            fig.set_label(
                f"Residual of {check.name} over the noise it passes on, per frequency band (1: the model explains "
                "the data in that band). A band far above the dashed line holds something the model lacks, which "
                "the whole-record ratio can hide")
            evidence.append(fig)
    if opts is not None:
        interval_sections(report, selection.outcomes, opts.likelihood, units)


def posterior_sections(report: Report, evidences, likelihood: str, units: ChannelUnits,
                       intro: str | None = None) -> None:
    """The arviz summaries (and figures) of the coefficient posteriors given the identified linear part.

    Parameters
    ----------
    report : Report
    evidences : mapping of str to EvidenceResult
        The evidence of each model shown, by name.
    likelihood : str
    units : ChannelUnits
    intro : str, optional
        A sentence before them.
    """
    post = report.section("Coefficient posteriors given the identified linear part", POSTERIOR)
    if not post:
        post.append("arviz summaries of the emcee draws under the primary likelihood (one chain per walker); the "
                    "files posterior/<name>.nc hold them with the honest intervals' draws (docs/posterior-files.md). "
                    "These HDIs condition on the identified linear part as if it were exact and are too narrow: "
                    "the 95 % intervals of the answer include its uncertainty.")
    if intro:
        post.append(intro)
    for name, evidence in evidences.items():
        post.append(f"{name} - log evidence {value_with_error(evidence.log_evidence, evidence.log_evidence_se)} nat; "
                    f"priors: {evidence.priors_text.replace(chr(10), '; ')}")
        post.append(summary_frame(evidence.summary))
        for message in evidence.warnings:
            post.append(("warning", message))
        if evidence.posterior.coefficients.shape[-1] and report.figures:
            from ..plots import plot_posterior_pairs

            fig = plot_posterior_pairs(evidence.posterior, units=units)
            fig.set_label(f"Posterior of the coefficients given the linear part, {name} (arviz-plots)")
            post.append(fig)
