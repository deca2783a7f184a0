# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Silverbox: measured data, and closing the loop
#
# The Silverbox (Wigren & Schoukens 2013) is an electronic circuit that behaves as a forced
# Duffing oscillator: a second-order linear system with a static cubic stiffness in feedback.
# Input `V1` plays the force, output `V2` the displacement (volts; errors in mV). The data are
# measured, not simulated, and live beside the repository in `../shared/data/silverbox/`
# (see its README for the source and the benchmark rules).
#
# The experiment is described by `workflows/silverbox/silverbox.toml`: estimation on the
# official split `[40650, 105712)` (random-phase multisines) and the benchmark's three test
# sets as validation segments, used for closed-loop simulation only, never for a decision.
#
# This notebook
#
# 1. identifies a linear and a cubic model by NSI;
# 2. simulates both in closed loop on the three test segments and compares the RMS errors with
#    published results of recurrent neural networks;
# 3. starts from the linear model and lets `bayesnsi.loop.close_the_loop` find what it
#    lacks, then compares before and after.
#
# **Tiny-data switch.** `BAYESNSI_NOTEBOOK_SMALL=1` estimates from the first two multisine
# periods only, runs one step of the loop over a three-effect dictionary with a short emcee
# chain, and draws no figures. The test segments are always the full ones.

# %%
import io
import os
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd

SMALL = os.environ.get("BAYESNSI_NOTEBOOK_SMALL", "") not in ("", "0")
if SMALL:
    matplotlib.use("Agg")  # no figure output, nothing to render

import matplotlib.pyplot as plt
from IPython.display import Image, display

from bayesnsi.loop import close_the_loop
from bayesnsi.io import load_config, load_signals, load_validation
from bayesnsi.nsi import identify
from bayesnsi.plots import plot_effect_force, plot_reconstruction_errors
from bayesnsi.tables import coefficients_table, modes_table

N_INIT = 50  # benchmark rule: the first 50 measured outputs may set the initial state
pd.set_option("display.precision", 4)


def show(fig):
    """Display a figure inline as a PNG (full mode) and release it.

    Rendered explicitly so each figure shows exactly once, whatever the backend (small mode
    uses the non-interactive Agg backend), and is then closed.
    """
    if not SMALL:
        png = io.BytesIO()
        fig.savefig(png, format="png", dpi=100, bbox_inches="tight")
        display(Image(png.getvalue()))
    plt.close(fig)


def repository_root(start):
    """The first folder at or above ``start`` that holds the Silverbox workflow, or None."""
    for folder in (start, *start.parents):
        if (folder / "workflows" / "silverbox" / "silverbox.toml").is_file():
            return folder
    return None


ROOT = repository_root(Path.cwd().resolve())
config = None
if ROOT is not None:
    config = load_config(ROOT / "workflows" / "silverbox" / "silverbox.toml", check_files=False)
HAVE_DATA = config is not None and config.data.file.is_file()
if HAVE_DATA:
    print(f"config {config.path}\ndata   {config.data.file}")
elif config is None:
    print("SKIPPED: workflows/silverbox/silverbox.toml not found above the working folder; "
          "run this notebook from the repository's notebooks/ folder. The cells below do nothing.")
else:
    print(f"SKIPPED: the Silverbox data are not present (looked for {config.data.file}); "
          "put the benchmark files in ../shared/data/silverbox/ beside the repository. "
          "The cells below do nothing.")

# %% [markdown]
# ## 1. Load
#
# `load_signals` cuts the estimation window and removes its means; `load_validation` cuts the
# test segments and removes the same (estimation) means, so nothing is learnt from test data.

# %%
if HAVE_DATA:
    signals = load_signals(config)
    if SMALL:
        signals = signals.segment(0, 2 * 8693)  # two multisine periods (8192 samples + transient)
    validation = load_validation(config)
    nsi_options = config.nsi  # NSIOptions from the config's [nsi] table
    print(f"estimation: {signals.n_samples} samples at {signals.fs:.4f} Hz, "
          f"rms V1 {1e3 * signals.force.std():.2f} mV, rms V2 {1e3 * signals.displacement.std():.2f} mV")
    for name, segment in validation:
        print(f"{name}: {segment.n_samples} samples, rms V2 {1e3 * segment.displacement.std():.2f} mV")
    print("NSI settings:", nsi_options.to_dict())

# %% [markdown]
# ## 2. Identify a linear and a cubic model
#
# Two candidates of the config: no nonlinear term, and the Duffing term `x1**3`. The circuit's
# output is not a pure displacement, so the config lets NSI identify a direct feedthrough.

# %%
if HAVE_DATA:
    candidates = {c.name: c for c in config.candidates if c.name in ("linear", "cubic")}
    results = {name: identify(signals, candidate, nsi_options) for name, candidate in candidates.items()}
    display(modes_table(results))
    display(coefficients_table({"cubic": results["cubic"]}))

# %% [markdown]
# ## 3. Closed-loop errors on the test segments
#
# Each model is simulated with the nonlinear term fed back from its own output (no measured
# output enters after the first 50 samples), and the RMS error is scored on the rest, in mV, as
# the benchmark asks. Published figures for comparison: Champneys et al., "Baseline Results for
# Selected Nonlinear System Identification Benchmarks", IFAC-PapersOnLine 58(15), 2024 (values
# as tabulated in `../shared/data/silverbox/README.md`).

# %%
PUBLISHED_MV = pd.DataFrame(
    {
        "LSTM": [1.50, 2.68, 0.96],
        "GRU": [1.49, 2.80, 0.95],
        "RNN": [1.64, 4.88, 1.73],
    },
    index=["test multisine", "test arrow full", "test arrow no extrapolation"],
)


def closed_loop(result, segments):
    """Closed-loop reconstructions of ``result`` on each (name, Signals) segment."""
    return {name: result.reconstruct(segment, closed_loop=True, n_init=N_INIT) for name, segment in segments}


def rmse_mv(reconstructions):
    """RMS closed-loop error after the first N_INIT samples, in mV, per segment."""
    rmse = {name: np.sqrt(np.mean(rec.residual[N_INIT:] ** 2)) for name, rec in reconstructions.items()}
    return 1e3 * pd.Series(rmse)


if HAVE_DATA:
    simulated = {name: closed_loop(result, validation) for name, result in results.items()}
    errors = pd.DataFrame({f"{name} (NSI)": rmse_mv(recs) for name, recs in simulated.items()})
    errors = errors.join(PUBLISHED_MV)
    errors.index.name = "RMS error [mV]"
    display(errors)

# %%
if HAVE_DATA:
    ax = errors.T.plot.bar(logy=True, figsize=(8.0, 3.6), rot=0)
    ax.set_ylabel("closed-loop RMS error [mV]")
    ax.set_title("Silverbox test segments")
    ax.legend(fontsize=8)
    show(ax.figure)

# %% [markdown]
# ## 4. Close the loop from the linear model
#
# `close_the_loop` ranks each effect of a dictionary (x², x|x|, x³, sign(v), v|v|, v³,
# x²·sign(v) and clearances at the measured DOF) by a frequency-domain screen (how much of the
# output its input explains), adds the best six in turn to the current model, identifies each by
# NSI and scores it by its Laplace log-evidence; the best is checked with the full evidence and kept
# only if the log Bayes factor exceeds log 100, its quality index |Im λ|/|Re λ| is below 0.3 and
# its coefficient keeps sign and size on both halves of the record. It repeats from the enlarged
# model (up to three effects here). The test segments play no part in it.

# %%
if HAVE_DATA:
    evidence_options = config.evidence  # its residual is replaced by the loop's (config.loop.residual)
    loop_options = config.loop.replace(max_steps=3)  # effects=None: the full dictionary
    if SMALL:
        evidence_options = evidence_options.replace(n_steps=200, n_burn=50)
        loop_options = loop_options.replace(max_steps=1, effects=("x^2", "x^3", "v|v|"))
    loop = close_the_loop(signals, candidates["linear"], loop_options, nsi=nsi_options, evidence=evidence_options)
    steps = pd.DataFrame(
        [
            {
                "effect": step.term.name,
                "accepted": step.accepted,
                "reason": step.reason,
                "coefficient": step.coefficient,
                "hdi95": f"[{step.ci95[0]:.4g}, {step.ci95[1]:.4g}]",
                "|Im|/|Re|": step.imag_ratio,
                "halves": f"{step.half_coefficients[0]:.4g} / {step.half_coefficients[1]:.4g}",
                "log Bayes factor": step.log_bayes_factor,
                "NRMSE before": step.nrmse_before,
                "NRMSE after": step.nrmse_after,
                "closed-loop NRMSE before": step.closed_loop_nrmse_before,
                "closed-loop NRMSE after": step.closed_loop_nrmse_after,
            }
            for step in loop.steps
        ]
    )
    print("final model:", ", ".join(t.name for t in loop.final.terms) or "linear")
    display(steps)

# %% [markdown]
# The Laplace scores of the first step, best first (log-evidence relative to the best effect;
# NaN for the effects the screen left out):

# %%
if HAVE_DATA:
    first = pd.DataFrame(
        [(row.effect.name, row.term.name, row.log_evidence) for row in loop.scores[0]],
        columns=["type", "term", "log Z (Laplace)"],
    )
    first["Δ log Z"] = first["log Z (Laplace)"] - first["log Z (Laplace)"].max()
    display(first.head(10))

# %% [markdown]
# ## 5. Before and after
#
# Closed-loop errors on the test segments of the starting (linear) and the final model, beside
# the hand-picked cubic model and the published networks, then for each added effect the
# residual of the model before and after it as a force against displacement and velocity (a
# restoring-force view: before, what the linear model could not absorb; after, a flat cloud
# about zero) and the closed-loop error on the full arrow segment (the amplitude grows with time,
# beyond the range of the estimation data near the end).

# %%
if HAVE_DATA:
    final_recs = closed_loop(loop.final, validation)
    before_after = pd.DataFrame(
        {
            "before (linear)": errors["linear (NSI)"],
            "after: " + (" + ".join(t.name for t in loop.final.terms) or "linear"): rmse_mv(final_recs),
            "cubic (NSI)": errors["cubic (NSI)"],
        }
    ).join(PUBLISHED_MV)
    before_after.index.name = "RMS error [mV]"
    display(before_after)

# %%
if HAVE_DATA:
    for step in loop.added:
        show(plot_effect_force(step, signals))
    arrow = {"before (linear)": simulated["linear"]["test arrow full"], "after": final_recs["test arrow full"]}
    show(plot_reconstruction_errors(arrow, fs=signals.fs))
