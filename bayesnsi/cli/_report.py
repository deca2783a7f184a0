"""Report content shared by the commands (figures and tables of an identification)."""

from __future__ import annotations

import numpy as np

from ..io import versions
from ..io.report import Report
from ..nsi import stabilization
from ..tables import coefficients_table, modes_table

__all__ = ["identification_report"]


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


def first_result(results):
    """The first successful result."""
    return next(iter(results.values()))


def _exact_frf(config, result, freqs):
    """Exact H[out0, in0] of the simulated case's underlying linear structure, if its matrices are known."""
    from ..simulate import underlying_frf

    meta = config.meta or {}
    dofs = (result.output_dofs[0], result.input_dofs[0])
    if not all(k in meta for k in ("M", "C", "K")) or len(meta["M"]) < max(dofs):
        return None
    frf = underlying_frf(meta["M"], meta["C"], meta["K"], freqs, result.output_dofs[:1], result.input_dofs[:1])
    return frf[:, 0, 0]


def identification_report(config, signals, results, records, title, report=None) -> Report:
    """Sections: settings, modes and coefficients tables, FRFs, λ(ω), singular values, stabilisation."""
    from ..plots import plot_coefficient_spectrum, plot_frf, plot_singular_values, plot_stabilization

    report = report or Report(title)
    intro = report.section("Data and settings")
    intro.append(
        f"{signals.n_samples} samples at {signals.fs:g} Hz; forces at DOFs {list(signals.input_dofs)}, "
        f"displacements at DOFs {list(signals.output_dofs)}; config {config.path}."
    )
    intro.append(("pre", "\n".join(f"{k} = {v!r}" for k, v in vars(config.nsi).items())))
    listed = "\n".join(f"  {k} {v}" for k, v in versions().items())
    intro.append(("pre", f"seed = {config.seed}\nversions:\n{listed}"))
    failed = [r for r in records if r.get("status") == "failed"]
    if failed:
        intro.append("Failed candidates: " + "; ".join(f"{r['name']}: {r['error']}" for r in failed))
    if not results:
        return report
    exact_f, exact_z, exact_coefs = _exact(config)
    tables = report.section("Identified modes and coefficients (paper Tables 3-4, 6-7, 9-10)")
    tables.append(modes_table(results, exact_f, exact_z))
    if any(r.terms for r in results.values()):
        tables.append(coefficients_table({k: r for k, r in results.items() if r.terms}, exact_coefs))
    nrmse = {r["name"]: r.get("nrmse") for r in records}
    import pandas as pd

    tables.append(pd.DataFrame({"open-loop NRMSE": nrmse}))
    figs = report.section("Figures")
    fmax = 1.3 * max(m.frequency_hz for r in results.values() for m in r.modes)
    freqs = np.linspace(fmax / 400, fmax, 800)
    fig = plot_frf(list(results.values()), freqs, exact=_exact_frf(config, first_result(results), freqs))
    fig.set_label("Underlying linear FRF of each candidate (paper Figs. 4, 8, 12)")
    figs.append(fig)
    for name, res in results.items():
        fig = plot_singular_values(res)
        fig.set_label(f"Singular values, {name} (paper Figs. 3, 7, 11)")
        figs.append(fig)
        if res.terms:
            fig = plot_coefficient_spectrum(res)
            fig.set_label(f"Re and Im of λ(ω), {name} (paper Fig. 5)")
            figs.append(fig)
    first_name, first = next(iter(results.items()))
    sv, diagram = stabilization(
        signals, first.candidate, block_rows=first.block_rows, velocity_method=first.settings["velocity_method"]
    )
    fig = plot_stabilization(sv, diagram, fmax_hz=fmax)
    fig.set_label(f"Stabilisation diagram, {first_name}")
    figs.append(fig)
    return report


_RESIDUAL_TEXT = {
    "reconstruction": "open-loop reconstruction residual",
    "innovations": "one-step-ahead innovations of the Kalman predictor that carries the input noise",
}


def selection_sections(report, signals, selection, selected):
    """Sections of a selection: probabilities side by side, adequacy, posteriors, reconstruction errors."""
    import pandas as pd

    from ..plots import plot_model_probabilities, plot_posterior_pairs, plot_reconstruction_errors, plot_traces

    results, evidences, table, opts = selection.results, selection.evidences, selection.table, selection.evidence
    head = report.section("Model selection (paper Eqs. 1-4 and marginal evidence)")
    head.append(
        f"Selected: {selected} (posterior under the marginal evidence with an {opts.likelihood} model of the "
        f"{_RESIDUAL_TEXT.get(opts.residual, opts.residual)}). "
        "The plain ranking is the paper's Gaussian likelihood of the open-loop reconstruction residual with "
        "σ̂² = mean squared residual; the evidence integrates the coefficients and the noise scale over stated "
        "proper priors (emcee + bridge sampling)."
    )
    head.append(table)
    if selection.adequacy:
        head.append(
            "Adequacy: the probabilities compare the candidates with each other; the Ljung-Box test of each "
            f"candidate's {_RESIDUAL_TEXT.get(opts.residual, opts.residual)} asks whether it explains the data "
            "(a white residual). A selected model that is not adequate lacks an effect no candidate declares: "
            "`bayesnsi diagnose` searches for it."
        )
        head.append(
            pd.DataFrame(
                {
                    name: {
                        "Ljung-Box p (worst channel)": min(w.p_value),
                        "lags outside ±1.96/√N (worst channel)": max(w.fraction_outside),
                        "white residual": w.adequate,
                    }
                    for name, w in selection.adequacy.items()
                }
            ).T
        )
    fig = plot_model_probabilities(table)
    fig.set_label("Posterior model probabilities under each ranking (error bars: Monte-Carlo sd)")
    head.append(fig)
    if not results:
        return report
    recs = {name: res.reconstruct(signals) for name, res in results.items()}
    fig = plot_reconstruction_errors(recs, signals.fs)
    fig.set_label("Open-loop reconstruction error of each candidate, first output (paper Figs. 9, 13)")
    head.append(fig)
    post = report.section("Coefficient posteriors (arviz summaries)")
    for name, by_lik in evidences.items():
        ev = by_lik[opts.likelihood]
        post.append(f"{name} - priors: {ev.priors_text.replace(chr(10), '; ')}")
        post.append(ev.summary)
        for message in ev.warnings:
            post.append(f"warning: {message}")
        if ev.posterior.coefficients.shape[-1]:
            fig = plot_posterior_pairs(ev.posterior)
            fig.set_label(f"Posterior of the coefficients, {name}")
            post.append(fig)
            fig = plot_traces(ev.posterior)
            fig.set_label(f"Traces of six walkers, {name}")
            post.append(fig)
    return report
