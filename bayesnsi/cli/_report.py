"""Report content shared by the commands: the answer first, then the evidence, models, figures, settings.

Sections are placed by ``order`` (:class:`bayesnsi.io.report.Report`): the answer (0), the loop of
``diagnose`` (10), the evidence of every candidate (20), the identified models (30), figures (40),
posteriors (50), data and settings (80), versions (90). Numbers come from the library; this module
arranges and words them.
"""

from __future__ import annotations

import contextlib

import numpy as np

from ..io import versions
from ..io.report import Report
from ..io.units import ChannelUnits
from ..nsi import stabilization
from ..tables import coefficients_table, modes_table, physical_table
from ..validation import whiteness_applies
from ._report_choices import frf_band, measured_text, overlay_channels, plausible_text
from ._report_intervals import interval_sections
from ._report_periodic import periodic_section
from ._report_tables import (
    adequacy_frame,
    decision_frame,
    model_check_frame,
    probability_text,
    ranking_frame,
    summary_frame,
)

__all__ = [
    "ANSWER", "LOOP", "EVIDENCE", "MODELS", "FIGURES", "POSTERIOR", "SETTINGS", "VERSIONS",
    "identification_answer", "identification_report", "selection_sections", "report_units",
]

ANSWER, LOOP, EVIDENCE, MODELS, FIGURES, POSTERIOR, SETTINGS, VERSIONS = 0, 10, 20, 30, 40, 50, 80, 90

_RESIDUAL_TEXT = {
    "reconstruction": "open-loop reconstruction residual",
    "innovations": "one-step-ahead innovations of the Kalman predictor that carries the input noise",
}
_LIKELIHOOD_TEXT = {"white": "white Gaussian", "ar1": "AR(1) Gaussian", "arP": "AR(P) Gaussian"}
_RECONSTRUCTION_SAMPLES = 400  # samples shown in the measured-vs-model overlays


@contextlib.contextmanager
def held_figures():
    """A report's figures stay open until it is written (each is closed as it is rendered).

    Matplotlib warns past 20 open figures; a ``diagnose`` report with posteriors of many
    candidates holds more, on purpose, so the warning is off inside this block only.
    """
    import matplotlib

    with matplotlib.rc_context({"figure.max_open_warning": 0}):
        yield


def report_units(config) -> ChannelUnits:
    """Units the config's data file states (empty where it states none or cannot be read again).

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    ChannelUnits
    """
    from ..exceptions import BayesNSIError
    from ..io.units import data_units

    try:
        return data_units(config)
    except (BayesNSIError, OSError, KeyError):
        return ChannelUnits()


def _exact(config):
    meta = config.meta or {}
    if "exact_frequencies_hz" not in meta:
        return None, None, None
    coefs = None
    if meta.get("true_model"):
        cand = next((c for c in config.candidates if c.name == meta["true_model"]), None)
        if cand is not None and len(cand.terms) == len(meta.get("true_coefficients", [])):
            coefs = {t.name: v for t, v in zip(cand.terms, meta["true_coefficients"])}
    return meta["exact_frequencies_hz"], meta.get("exact_damping_ratios"), coefs


def _exact_frf(config, result, freqs):
    """Exact underlying FRF (n_freq, l, m) of a simulated case whose matrices are in the config's [meta]."""
    from ..simulate import underlying_frf

    meta = config.meta or {}
    dofs = tuple(result.output_dofs) + tuple(result.input_dofs)
    if not all(k in meta for k in ("M", "C", "K")) or len(meta["M"]) < max(dofs):
        return None
    return underlying_frf(meta["M"], meta["C"], meta["K"], freqs, result.output_dofs, result.input_dofs)


def identification_report(config, signals, results, records, title, report=None, units=None,
                          data_warnings=()) -> Report:
    """Sections of an identification: models, figures (FRF, λ(ω), singular values, stabilisation), settings.

    Parameters
    ----------
    config : ExperimentConfig
    signals : Signals
    results : mapping of str to NSIResult
    records : list of dict
        The candidates' results.json records (for NRMSE and failures).
    title : str
    report : Report, optional
    units : ChannelUnits, optional
    data_warnings : sequence of str
        What loading the data warned about (shown in "Data and settings").

    Returns
    -------
    Report
    """
    from ..plots import plot_coefficient_spectrum, plot_frf, plot_singular_values, plot_stabilization

    units = units or report_units(config)
    report = report or Report(title)
    _settings_sections(report, config, signals, records, units, data_warnings)
    periodic_section(report, signals, units)  # periodic data: BLA figure and distortion level
    if not results:
        report.section("Answer", ANSWER).append(
            ("warning", "No candidate could be identified (see Data and settings).")
        )
        return report
    exact_f, exact_z, exact_coefs = _exact(config)
    tables = report.section("Identified models (paper Tables 3-4, 6-7, 9-10)", MODELS)
    tables.append("Natural frequencies and damping ratios of each candidate's underlying linear model.")
    tables.append(modes_table(results, exact_f, exact_z))
    physical = physical_table(results)
    if not physical.empty:  # one-DOF models (e.g. a free body, whose rigid-body pole is no mode)
        tables.append("Lumped parameters of the one-DOF models from the identified FRF (1/H = K - Mω² + jωC).")
        tables.append(physical)
    elif any(len(r.rigid_body_poles) for r in results.values()):  # a free body with several DOFs
        tables.append(_rigid_body_note(results))
    if any(r.terms for r in results.values()):
        tables.append(
            "Nonlinear coefficients: the NSI estimate (mean real part of λ(ω) over the band of the modes) and its "
            "quality index |Im|/|Re| (small is good)."
        )
        frame = coefficients_table({k: r for k, r in results.items() if r.terms}, exact_coefs)
        tables.append(frame.rename(index=lambda t: _with_unit(t, units)))
    import pandas as pd

    nrmse = {r["name"]: r.get("nrmse") for r in records}
    tables.append(pd.DataFrame({"open-loop reconstruction error (NRMSE)": nrmse}).rename_axis("candidate"))
    figs = report.section("Figures", FIGURES)
    fmax, measured, wide = frf_band(signals, results)
    freqs = np.geomspace(fmax / 400, fmax, 800) if wide else np.linspace(fmax / 400, fmax, 800)
    first_name, first = next(iter(results.items()))
    fig = plot_frf(list(results.values()), freqs, exact=_exact_frf(config, first, freqs), units=units,
                   measured=measured, log_frequency=wide)
    fig.set_label("Underlying linear FRF of each candidate, magnitude and phase, every force/response pair "
                  "(paper Figs. 4, 8, 12), over the band the force excites, beside the data's own FRF (grey, H1: "
                  "Welch cross spectra, no model, shown where its coherence is at least 0.5; for a nonlinear "
                  "structure the linearisation at the test's level). A peak of the data that no model has is a mode "
                  "the models lack (a higher [nsi] order)")
    figs.append(fig)
    for name, res in results.items():
        if res.terms:
            fig = plot_coefficient_spectrum(res, units=units)
            fig.set_label(f"Re and Im of λ(ω), {name}: the estimate averages Re λ over the grey band (paper Fig. 5)")
            figs.append(fig)
    for name, res in results.items():
        fig = plot_singular_values(res)
        fig.set_label(f"Singular values, {name} (paper Figs. 3, 7, 11)")
        figs.append(fig)
    sv, diagram = stabilization(
        signals, first.candidate, block_rows=first.block_rows, velocity_method=first.settings["velocity_method"]
    )
    fig = plot_stabilization(sv, diagram, fmax_hz=fmax)
    fig.set_label(f"Stabilisation diagram, {first_name}")
    figs.append(fig)
    return report


def identification_answer(report, signals, results, records, units) -> None:
    """The answer of ``identify``: what was identified (it ranks nothing), and the reconstructions.

    Parameters
    ----------
    report : Report
    signals : Signals
    results : mapping of str to NSIResult
    records : list of dict
        The candidates' results.json records.
    units : ChannelUnits
    """
    import pandas as pd

    answer = report.section("Answer", ANSWER)
    answer.append((
        "lead",
        f"Identified {len(results)} of {len(records)} candidates by nonlinear subspace identification. "
        "`bayesnsi identify` does not compare them; `bayesnsi select` ranks them by Bayesian evidence.",
    ))
    rows = {
        name: {
            "model order": res.order,
            "natural frequencies [Hz]": ", ".join(f"{m.frequency_hz:.4g}" for m in res.modes),
            "coefficients": "; ".join(f"{c.term.name} = {c.value:.4g}" for c in res.coefficients) or "—",
        }
        for name, res in results.items()
    }
    if rows:
        answer.append(pd.DataFrame(rows).T.rename_axis("candidate"))
    _reconstruction_figures(report, signals, results, units)


def answer_data_warnings(report, data_warnings) -> None:
    """Close the Answer with a pointer to what loading the data warned about (shown in "Data and settings").

    Parameters
    ----------
    report : Report
    data_warnings : sequence of str
        ``args.data_warnings`` of :func:`bayesnsi.cli._common.start_run`.
    """
    if data_warnings:
        report.section("Answer", ANSWER).append(("warning", f"Loading the data gave {len(data_warnings)} warning(s), "
                                                 "shown under Data and settings: read them before the answer above "
                                                 "(e.g. an integration band that starts in the sensors' noise)."))


def _settings_sections(report, config, signals, records, units, data_warnings=()) -> None:
    intro = report.section("Data and settings", SETTINGS)
    for message in data_warnings:
        intro.append(("warning", f"Loading the data: {message}"))
    stated = ", ".join(f"{q} in {getattr(units, q)}" for q in ("force", "displacement") if getattr(units, q))
    intro.append(
        f"{signals.n_samples} samples at {signals.fs:g} Hz; forces at DOFs {list(signals.input_dofs)}, "
        f"displacements at DOFs {list(signals.output_dofs)}{measured_text(config)}; "
        + (f"units from the data file: {stated}; " if stated else "the data file states no units; ")
        + f"config {config.path.name}; seed {config.seed}."
    )
    intro.append(("pre", "[nsi]\n" + "\n".join(f"{k} = {v!r}" for k, v in vars(config.nsi).items())))
    intro.append(("pre", "[evidence]\n" + "\n".join(f"{k} = {v!r}" for k, v in vars(config.evidence).items())))
    failed = [r for r in records if r.get("status") == "failed"]
    if failed:
        intro.append(("warning", "Failed candidates: " + "; ".join(f"{r['name']}: {r['error']}" for r in failed)))
    listed = "\n".join(f"{k} {v}" for k, v in versions().items())
    report.section("Versions", VERSIONS).append(("pre", listed))


def selection_sections(report, signals, selection, selected, units=None, role: str = "Selected"):
    """Sections of a selection: the answer with Bayes factors, the evidence table, adequacy, posteriors.

    Parameters
    ----------
    report : Report
    signals : Signals
    selection : Selection
    selected : str or None
        The candidate to present as the answer.
    units : ChannelUnits, optional
    role : str
        How the answer names ``selected`` (``diagnose``: the starting model).

    Returns
    -------
    Report
    """
    units = units or ChannelUnits()
    results, evidences, table, opts = selection.results, selection.evidences, selection.table, selection.evidence
    answer = report.section("Answer", ANSWER)
    residual = _RESIDUAL_TEXT.get(opts.residual, opts.residual)
    decision = None
    if table is not None and selected is not None and f"log_evidence_{opts.likelihood}" in table:
        from ..evidence.decision import decision_table

        decision = decision_table(table, opts.likelihood, selected)
        checks = getattr(selection, "checks", None) or {}
        none_adequate = bool(checks) and not any(c.adequate for c in checks.values())
        answer.append(("lead", _answer_text(decision, selected, opts, role) + (
            " The probability compares these candidates only: none of them explains the data down to the noise "
            "(warnings below), so it says which is least wrong, not that it is right." if none_adequate else "")
            + plausible_text(selection, selected, decision)))
        answer.append(decision_frame(decision, selected))
        answer.append(
            f"Evidence: marginal likelihood of each candidate, the {residual} modelled as "
            f"{_LIKELIHOOD_TEXT.get(opts.likelihood, opts.likelihood)} noise (coefficients and noise level integrated "
            "over proper priors: the noise levels in closed form where the likelihood allows, the coefficients by "
            "MCMC, the evidence by bridge sampling; docs/method.md §6). The log Bayes factor is the difference of "
            "log evidences "
            "[nat]; the words are Kass and "
            "Raftery's (1 nat: barely worth mentioning, 3: strong, 5: very strong). ± are Monte-Carlo errors."
        )
    else:
        answer.append(("warning", "No candidate has an evidence: there is no selection to report."))
    for message in _warnings(selection, selected, evidences, opts):
        answer.append(("warning", message))
    if decision is not None and len(decision) > 1:
        from ..plots import plot_bayes_factors

        fig = plot_bayes_factors(decision, selected)
        fig.set_label("Log Bayes factor of the selected model against each other candidate (±2 Monte-Carlo "
                      "standard errors; symmetric-log axis beyond 10 nat)")
        answer.append(fig)
    evidence = report.section("Evidence and adequacy of every candidate (paper Eqs. 1-4)", EVIDENCE)
    if table is not None:
        evidence.append(
            "The paper's plain ranking uses a Gaussian likelihood of the open-loop reconstruction residual with "
            "σ̂² set to each model's own mean squared residual; with thousands of samples it gives 0 or 1 and "
            "favours the largest model. The evidence columns integrate over the coefficients instead."
        )
        evidence.append(ranking_frame(table))
    if selection.adequacy:
        evidence.append(
            f"Adequacy: a Ljung-Box test of each candidate's {residual} asks whether the model explains the data "
            "(a white residual). The probabilities only compare the candidates with each other."
        )
        evidence.append(adequacy_frame(selection.adequacy))
    elif selection.checks and not whiteness_applies(signals):
        evidence.append(
            f"Adequacy: no whiteness test - the responses were integrated from "
            f"{ {'acceleration': 'accelerations', 'velocity': 'velocities'}.get(signals.measured, signals.measured)}, "
            "whose noise the integration colours, so no model's residual is white; the residual against that "
            "integrated noise (below) says whether a model explains the data."
        )
    if selection.checks:
        evidence.append(
            "Model check: each candidate's open-loop residual rms over the noise it passes on - the change of its "
            "residual when fresh sensor noise is added to the data (a model that explains the data leaves about 1x; "
            "above max_noise_ratio it is not adequate and its intervals are widened by the ratio) - the same band by "
            "band, the quality index of its coefficients and, with validation data, its closed-loop error."
        )
        evidence.append(model_check_frame(selection.checks))
        _band_figure(evidence, signals, selection.checks.get(selected), opts.max_band_ratio)
    interval_sections(report, selection.outcomes, selected, opts.likelihood, answer, MODELS)
    _reconstruction_figures(report, signals, results, units)
    post = report.section("Coefficient posteriors", POSTERIOR)
    post.append("arviz summaries of the emcee draws (one chain per walker); the draws are in posterior/<name>.nc. "
                "Their HDI is the posterior's alone, given the identified linear part (too narrow: the intervals "
                "that include the linear part's uncertainty are in 'Intervals of coefficients and modes').")
    for name, by_lik in evidences.items():
        ev = by_lik[opts.likelihood]
        post.append(f"{name} - priors: {ev.priors_text.replace(chr(10), '; ')}")
        post.append(summary_frame(ev.summary))
        for message in ev.warnings:
            post.append(("warning", message))
        if ev.posterior.coefficients.shape[-1]:
            from ..plots import plot_posterior_pairs, plot_traces

            fig = plot_posterior_pairs(ev.posterior, units=units)
            fig.set_label(f"Posterior of the coefficients, {name} (arviz-plots)")
            post.append(fig)
            fig = plot_traces(ev.posterior, units=units)
            fig.set_label(f"Traces of six walkers, {name} (arviz-plots)")
            post.append(fig)
    return report


def _band_figure(section, signals, check, limit: float) -> None:
    """The selected model's residual over the noise it passes on, band by band (bayesnsi.run.residual_bands)."""
    if check is None or not check.band_ratios:
        return
    from ..plots import plot_band_ratios

    names = list(signals.output_names) or [f"DOF {d}" for d in signals.output_dofs]
    fig = plot_band_ratios(check, names, limit)
    fig.set_label(
        f"Residual of {check.name} over the noise it passes on, per frequency band: the change of its residual when "
        "fresh sensor noise is added to the data (1: the model explains the data in that band). A band far above "
        "the dashed line holds something the model lacks, which the whole-record ratio can hide")
    section.append(fig)


def _answer_text(decision, selected, opts, role) -> str:
    row = decision.loc[selected]
    text = (
        f"{role}: {selected}, posterior probability {probability_text(row['probability'])} "
        f"(evidence with {_LIKELIHOOD_TEXT.get(opts.likelihood, opts.likelihood)} residuals)."
    )
    others = decision.drop(index=selected)
    if len(others):
        runner, bf = others.index[0], others.iloc[0]
        if np.isfinite(bf["log_bayes_factor"]):
            text += (
                f" Against the next best, {runner}: log Bayes factor {bf['log_bayes_factor']:.1f} "
                f"± {bf['log_bayes_factor_se']:.2g} nat ({bf['strength']})."
            )
        else:
            text += f" Every other candidate failed ({runner} first)."
    return text


def _warnings(selection, selected, evidences, opts):
    whiteness = selection.adequacy.get(selected) if selected else None
    if whiteness is not None and not whiteness.adequate:
        yield (
            f"The selected model's {whiteness.residual} residual is not white (Ljung-Box p = "
            f"{min(whiteness.p_value):.2g}): an effect may be missing from every candidate; "
            "`bayesnsi diagnose` searches for it."
        )
    for message in getattr(selection, "warnings", ()) or ():  # adequacy warnings of the selection, if any
        yield str(message)
    for outcome in selection.outcomes:
        if outcome.error is not None:
            yield f"{outcome.name}: {outcome.failed_stage or 'run'} failed - {outcome.error}"
    ev = evidences.get(selected, {}).get(opts.likelihood) if selected else None
    for message in getattr(ev, "warnings", ()) or ():
        yield f"{selected}: {message}"


def _reconstruction_figures(report, signals, results, units) -> None:
    if not results:
        return
    from ..plots import plot_reconstruction

    figs = report.section("Figures", FIGURES)
    recs = {name: res.reconstruct(signals) for name, res in results.items()}
    names = list(signals.output_names) if getattr(signals, "output_names", None) else None
    terms = [t for res in results.values() for t in res.terms]
    for channel in overlay_channels(signals, terms):  # a few outputs: the report stays quick
        label = names[channel] if names else f"x{signals.output_dofs[channel]}"
        fig = plot_reconstruction(
            recs, signals.fs, channel, units=units, channel_name=label, max_samples=_RECONSTRUCTION_SAMPLES
        )
        fig.set_label(f"Measured {label} and each candidate's open-loop reconstruction, with the errors, over the "
                      f"first {_RECONSTRUCTION_SAMPLES} samples (paper Figs. 9, 13)")
        figs.append(fig)


def _with_unit(term_name: str, units) -> str:
    """``"x3**3@3 [N/m^3]"``: a coefficient's row label with the unit of λ when the data state units."""
    from ..io.units import term_unit

    unit = term_unit(term_name.rsplit("@", 1)[0], units or ChannelUnits())
    return f"{term_name} [{unit}]" if unit else term_name


def _rigid_body_note(results) -> str:
    """Which candidates hold rigid-body poles (free body, several DOFs: no lumped parameters)."""
    parts = [
        f"{name}: {', '.join(f'{p.real:.3g}' + (f'{p.imag:+.3g}j' if p.imag else '') for p in r.rigid_body_poles)}"
        for name, r in results.items() if len(r.rigid_body_poles)
    ]
    return ("Rigid-body poles s [1/s] (a free body: identified with a virtual spring on the input, removed again; "
            "not modes): " + "; ".join(parts) + ".")
