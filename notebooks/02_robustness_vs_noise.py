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
# # Robustness against output noise
#
# The two-DOF case of notebook 01 (quadratic damping α = 20 N s²/m² at DOF 1, candidates
# model 1 = true, model 2 = Coulomb, model 3 = both) repeated at output noise levels of 1, 2,
# 5 and 10 % of each channel's standard deviation, a few noise realisations per level. For each
# realisation the three candidates are identified and ranked three ways:
#
# * **plain**: the paper's Eq. 4 (Gaussian likelihood at the maximum-likelihood noise level);
# * **evidence, AR(1)**: marginal evidence with AR(1) residuals (the library default);
# * **evidence, white**: marginal evidence with white residuals.
#
# We plot the posterior model probabilities and the error of the quadratic-damping coefficient
# against the noise level.
#
# **Tiny-data switch.** `BAYESNSI_NOTEBOOK_SMALL=1` runs one level with one seed and a short
# emcee chain, and draws no figures. The full run (4 levels x 5 seeds x 3 candidates x 2
# likelihoods) takes one to two minutes on one core.

# %%
import io
import os

import matplotlib
import numpy as np
import pandas as pd

SMALL = os.environ.get("BAYESNSI_NOTEBOOK_SMALL", "") not in ("", "0")
if SMALL:
    matplotlib.use("Agg")  # no figure output, nothing to render

import matplotlib.pyplot as plt
from IPython.display import Image, display

from bayesnsi import BayesNSIError, EvidenceOptions
from bayesnsi.evidence import candidate_evidence, compare_evidence
from bayesnsi.nsi import identify
from bayesnsi.simulate import simulate_cases

NOISE_PERCENT = [2.0] if SMALL else [1.0, 2.0, 5.0, 10.0]
SEEDS = [0] if SMALL else [0, 1, 2, 3, 4]
EVIDENCE = EvidenceOptions(n_steps=200, n_burn=50) if SMALL else EvidenceOptions()
RANKINGS = {"plain": "plain (Eq. 4)", "ar1": "evidence, AR(1)", "white": "evidence, white"}
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


print(f"noise levels {NOISE_PERCENT} %, seeds {SEEDS}, emcee {EVIDENCE.n_walkers} x {EVIDENCE.n_steps}")

# %% [markdown]
# ## 1. Identify and rank every realisation
#
# `simulate_cases` integrates all seeds of one noise level in one batched time loop. A
# candidate whose identification or evidence fails is recorded as failed (probability 0)
# rather than stopping the study.

# %%
rows = []
for level, noise in enumerate(NOISE_PERCENT):
    for case in simulate_cases("two-dof", SEEDS, noise_percent=noise):
        alpha_true = float(case.true_coefficients[0])
        alpha_name = case.true_terms[0].name
        settings = case.recommended  # NSIOptions: block_rows 60, order 4
        results, evidence = {}, {}
        for k, candidate in enumerate(case.candidates):
            try:
                results[candidate.name] = identify(case.signals, candidate, settings)
                seed = np.random.SeedSequence([case.seed, level, k])
                per = candidate_evidence(results[candidate.name], case.signals, EVIDENCE, seed, warn=not SMALL)
                evidence[candidate.name] = list(per.values())
            except BayesNSIError as err:
                print(f"noise {noise} %, seed {case.seed}, {candidate.name}: failed ({err})")
                evidence[candidate.name] = None
        table = compare_evidence(evidence, rng=case.seed)
        for name in table.index:
            row = {"noise %": noise, "seed": case.seed, "candidate": name, "true": name == case.true_model}
            row.update({f"p {key}": table.loc[name, f"p_{key}"] for key in RANKINGS})
            row["log score plain"] = table.loc[name, "log_likelihood_plain"]
            row.update({f"log score {key}": table.loc[name, f"log_evidence_{key}"] for key in ("ar1", "white")})
            result = results.get(name)
            nsi = {c.term.name: c.value for c in result.coefficients} if result else {}
            # the estimate each ranking reports: the NSI value (plain) or the posterior mean
            row["alpha plain"] = nsi.get(alpha_name, np.nan)
            for ev in evidence[name] or []:
                means = dict(zip(ev.coefficient_names, ev.coefficient_mean))
                row[f"alpha {ev.likelihood}"] = means.get(alpha_name, np.nan)
            rows.append(row)

study = pd.DataFrame(rows)
for key in RANKINGS:
    study[f"alpha error % {key}"] = 100 * (study[f"alpha {key}"] / alpha_true - 1)
study.set_index(["noise %", "seed", "candidate"])

# %% [markdown]
# ## 2. Model probabilities against noise
#
# Mean posterior probability of each candidate over the seeds (lines), with each seed as a dot.

# %%
probabilities = study.groupby(["noise %", "candidate"])[[f"p {key}" for key in RANKINGS]].mean()
probabilities.unstack("candidate")

# %%
fig, axes = plt.subplots(1, 3, figsize=(11.0, 3.4), sharey=True, layout="constrained")
for ax, (key, label) in zip(axes, RANKINGS.items()):
    for k, (name, group) in enumerate(study.groupby("candidate")):
        mean = group.groupby("noise %")[f"p {key}"].mean()
        ax.plot(mean.index, mean.values, "o-", color=f"C{k}", label=name)
        ax.plot(group["noise %"], group[f"p {key}"], ".", color=f"C{k}", alpha=0.35)
    ax.set_xscale("log")
    ax.set_xticks(NOISE_PERCENT, [f"{n:g}" for n in NOISE_PERCENT])
    ax.set_xlabel("output noise [%]")
    ax.set_title(label)
axes[0].set_ylabel("P(model | data)")
axes[0].set_ylim(-0.05, 1.05)
axes[0].legend(fontsize=8)
show(fig)

# %% [markdown]
# Probabilities this close to 0 and 1 hide how decisive each ranking is. The log odds of the
# true model against the best alternative, `log P(model 1|D) - max_k log P(model k|D)` (from the
# log scores; uniform model prior), keep the information: a value of 4.6 nats is odds of 100:1.

# %%
margins = []
for (noise, seed), group in study.groupby(["noise %", "seed"]):
    scores = group.set_index("candidate")
    for key in RANKINGS:
        true_score = scores.loc[scores["true"], f"log score {key}"].iloc[0]
        margins.append({"noise %": noise, "seed": seed, "ranking": key,
                        "log odds": true_score - scores.loc[~scores["true"], f"log score {key}"].max()})
margins = pd.DataFrame(margins)

fig, ax = plt.subplots(figsize=(6.0, 3.6), layout="constrained")
for k, (key, label) in enumerate(RANKINGS.items()):
    group = margins[margins["ranking"] == key]
    median = group.groupby("noise %")["log odds"].median()
    ax.plot(median.index, median.values, "o-", color=f"C{k}", label=f"{label} (median)")
    ax.plot(group["noise %"], group["log odds"], ".", color=f"C{k}", alpha=0.35)
ax.axhline(np.log(100.0), color="0.5", ls="--", lw=0.8, label="odds 100:1")
ax.set_xscale("log")
ax.set_yscale("symlog", linthresh=1.0)
ax.set_ylim(bottom=min(0.0, 2.0 * margins["log odds"].min()))  # negative: a wrong model wins
ax.set_xticks(NOISE_PERCENT, [f"{n:g}" for n in NOISE_PERCENT])
ax.set_xlabel("output noise [%]")
ax.set_ylabel("log odds, true vs best other [nat]")
ax.legend(fontsize=8)
show(fig)

# %% [markdown]
# How often each ranking selects each candidate (fraction of seeds):

# %%
picks = []
for (noise, seed), group in study.groupby(["noise %", "seed"]):
    for key in RANKINGS:
        picks.append({"noise %": noise, "ranking": key, "selected": group.loc[group[f"p {key}"].idxmax(), "candidate"]})
picks = pd.DataFrame(picks)
pd.crosstab([picks["ranking"], picks["noise %"]], picks["selected"], normalize="index")

# %% [markdown]
# ## 3. Coefficient errors against noise
#
# Left: the error of α reported by each ranking for the model it selects (the NSI estimate for
# the plain ranking, the posterior mean for the evidence rankings); a selected model without the
# quadratic-damping term would show -100 %. Right: the NSI estimate of α in model 1 (true) and
# model 3 (with the redundant Coulomb term), whatever is selected; the spread over seeds shows
# what the noise does to each.

# %%
selected = []
for (noise, seed), group in study.groupby(["noise %", "seed"]):
    for key in RANKINGS:
        best = group.loc[group[f"p {key}"].idxmax()]
        error = best[f"alpha error % {key}"]
        error = -100.0 if np.isnan(error) else error  # the selected model has no α term
        selected.append({"noise %": noise, "seed": seed, "ranking": key, "alpha error %": error})
selected = pd.DataFrame(selected)

fig, axes = plt.subplots(1, 2, figsize=(10.0, 3.6), layout="constrained")
offsets = dict(zip(RANKINGS, (0.94, 1.0, 1.06)))  # side by side on the log axis
for k, (key, label) in enumerate(RANKINGS.items()):
    group = selected[selected["ranking"] == key]
    stats = group.groupby("noise %")["alpha error %"].agg(["mean", "std"]).fillna(0.0)
    x = stats.index.to_numpy() * offsets[key]
    axes[0].errorbar(x, stats["mean"], yerr=stats["std"], fmt="o-", color=f"C{k}", capsize=3, label=label)
    axes[0].plot(group["noise %"] * offsets[key], group["alpha error %"], ".", color=f"C{k}", alpha=0.35)
axes[0].set_title("α of the selected model")
for k, name in enumerate(("model 1", "model 3")):
    group = study[study["candidate"] == name]
    stats = group.groupby("noise %")["alpha error % plain"].agg(["mean", "std"]).fillna(0.0)
    axes[1].errorbar(stats.index, stats["mean"], yerr=stats["std"], fmt="s-", color=f"C{k + 3}", capsize=3, label=name)
    axes[1].plot(group["noise %"], group["alpha error % plain"], ".", color=f"C{k + 3}", alpha=0.35)
axes[1].set_title("NSI estimate of α per candidate")
for ax in axes:
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xscale("log")
    ax.set_xticks(NOISE_PERCENT, [f"{n:g}" for n in NOISE_PERCENT])
    ax.set_xlabel("output noise [%]")
    ax.set_ylabel("α error [%]")
    ax.legend(fontsize=8)
show(fig)

# %%
summary = selected.groupby(["ranking", "noise %"])["alpha error %"].agg(["mean", "std", "min", "max"])
summary

# %% [markdown]
# ## Reading the figures
#
# * With 1000 samples per channel the candidates' log scores differ by tens to hundreds of
#   nats, so all three rankings are close to all-or-nothing at every level; the log odds show
#   the decisiveness shrinking as the noise grows and the candidates' fits come closer.
# * The AR(1) evidence is the least decisive of the three: residuals that are correlated from
#   sample to sample carry less information than the same number of independent ones, which the
#   plain ranking and the white-noise evidence assume. The evidence also charges an Occam factor
#   for each coefficient, which the plain ranking, scoring the best fit only, does not.
# * α of the selected (true) model scatters more as the noise grows; the redundant Coulomb term
#   of model 3 makes its α scatter far more, which is what selecting the right model avoids.
#   The three rankings report nearly the same α: the posterior mean sits at the NSI estimate.
#
# The small mode's single point says none of this; run the notebook without the switch.
