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
# # Two-DOF walkthrough: identify, compare, select
#
# The paper's first example (Zhu et al., *Bayesian Model Selection in Nonlinear Subspace
# Identification*, section III.A; `docs/method.md` §8): a two-DOF chain, force at DOF 2, displacement and
# velocity measured at both DOFs (2 % output noise, 10 s at 100 Hz), with **quadratic damping**
# `α v1|v1|` (α = 20 N s²/m²) at DOF 1. Three candidates are identified by nonlinear subspace
# identification (NSI):
#
# | candidate | nonlinear terms |
# | --- | --- |
# | model 1 (true) | `v1*abs(v1)` |
# | model 2 | `sign(v1)` (Coulomb friction) |
# | model 3 | `v1*abs(v1)` and `sign(v1)` |
#
# and then ranked twice: by the paper's plain ranking (Eq. 4, the Gaussian likelihood at the
# maximum-likelihood noise level) and by the marginal evidence (emcee + bridge sampling) under
# white and AR(1) residuals.
#
# **Tiny-data switch.** `BAYESNSI_NOTEBOOK_SMALL=1` in the environment runs a short emcee chain
# and draws no figures (the notebook test uses it); unset, the notebook uses the library's
# evidence defaults and shows every figure.

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

from bayesnsi import EvidenceOptions
from bayesnsi.evidence import candidate_evidence, compare_evidence
from bayesnsi.nsi import identify
from bayesnsi.plots import (
    plot_coefficient_spectrum,
    plot_frf,
    plot_model_probabilities,
    plot_posterior_pairs,
    plot_traces,
)
from bayesnsi.simulate import simulate_case
from bayesnsi.tables import coefficients_table, modes_table

SEED = 0
EVIDENCE = EvidenceOptions(n_steps=200, n_burn=50) if SMALL else EvidenceOptions()
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


print(f"small mode: {SMALL}; emcee: {EVIDENCE.n_walkers} walkers x {EVIDENCE.n_steps} steps")

# %% [markdown]
# ## 1. Simulate the structure
#
# `simulate_case` integrates the nonlinear equations of motion (RK4 on an 8x finer grid),
# adds the output noise and returns the data together with the exact linear system, the true
# coefficients and the paper's candidate set.

# %%
case = simulate_case("two-dof", seed=SEED)
signals = case.signals
print(case.describe())

# %% [markdown]
# ## 2. Identify the three candidates
#
# Each candidate is identified with the paper's settings (`block_rows = 60`, order 4). The
# result carries the underlying linear system, its modes and the nonlinear coefficients
# λ_i = mean Re λ_i(ω) over the band of the modes, with the quality index |Im|/|Re|.

# %%
settings = case.recommended  # NSIOptions: block_rows 60, order 4
results = {candidate.name: identify(signals, candidate, settings) for candidate in case.candidates}
exact = {term.name: value for term, value in zip(case.true_terms, case.true_coefficients)}

# %% [markdown]
# Natural frequencies and damping ratios against the exact underlying linear system (paper
# Table 3):

# %%
modes_table(results, case.exact_frequencies_hz, case.exact_damping_ratios)

# %% [markdown]
# Nonlinear coefficients (paper Table 4). The true model recovers α ≈ 20 with |Im|/|Re| of a
# few per cent. The Coulomb term of model 3, which is not in the structure, gets a small
# coefficient with a large |Im|/|Re|; model 2 has no damping term of the right form, so its
# Coulomb coefficient comes out negative (unphysical) and its damping ratios in the table above
# are several times too large. The quality index alone does not flag model 2: the ranking has to.

# %%
coefficients_table(results, exact)

# %% [markdown]
# ### Underlying linear FRF and λ(ω)
#
# The exact FRF `H(ω) = (K - ω² M + iω C)⁻¹` of the linear part, from DOF 2 (force) to DOF 1,
# beside the identified ones (paper Fig. 4). Then the frequency dependence of the estimated
# coefficients (paper Fig. 5): for a correct term, Re λ(ω) is flat and Im λ(ω) ≈ 0 over the band.

# %%
freqs_hz = np.linspace(0.5, 12.0, 600)
out_row = signals.output_dofs[0] - 1
in_col = signals.input_dofs[0] - 1
exact_frf = np.array(
    [np.linalg.inv(case.K - w**2 * case.M + 1j * w * case.C)[out_row, in_col] for w in 2 * np.pi * freqs_hz]
)
show(plot_frf(list(results.values()), freqs_hz, output_index=0, input_index=0, exact=exact_frf))

# %%
for name in ("model 1", "model 3"):
    show(plot_coefficient_spectrum(results[name]))

# %% [markdown]
# ## 3. Evidence of each candidate
#
# `candidate_evidence` builds the default priors of `docs/method.md` §6 from the data (coefficient scales
# from the rms of each nonlinear input and of the force), samples the posterior with emcee and
# estimates `log Z` by bridge sampling, under the primary likelihood (AR(1) residuals) and the
# white-noise one. The Laplace approximation and, where the dimension allows, the exact value by
# quadrature are computed beside it as checks.

# %%
seeds = np.random.SeedSequence(SEED).spawn(len(results))
evidence = {
    name: candidate_evidence(result, signals, EVIDENCE, seed_sequence=seed, warn=not SMALL)
    for (name, result), seed in zip(results.items(), seeds)
}
rows = []
for name, per_likelihood in evidence.items():
    for likelihood, ev in per_likelihood.items():
        rows.append(
            {
                "candidate": name,
                "likelihood": likelihood,
                "log Z (bridge)": ev.log_evidence,
                "MC se": ev.log_evidence_se,
                "log Z (Laplace)": ev.laplace_log_evidence,
                "log Z (exact)": ev.closed_form_log_evidence,
                "log L plain (Eq. 4)": ev.plain_log_likelihood,
                "r_hat max": ev.rhat_max,
                "ESS min": ev.ess_min,
            }
        )
pd.DataFrame(rows).set_index(["candidate", "likelihood"])

# %% [markdown]
# ## 4. Side-by-side ranking
#
# `compare_evidence` turns the results into posterior model probabilities (uniform prior over
# the candidates) beside the plain ranking of the paper. With 1000 samples per channel the
# differences of log scores are hundreds of nats, so every ranking is all-or-nothing; the log
# score differences to the best candidate show how decisive each one is.

# %%
table = compare_evidence({name: list(per.values()) for name, per in evidence.items()}, rng=SEED)
table

# %%
scores = table[["log_likelihood_plain", "log_evidence_ar1", "log_evidence_white"]]
(scores - scores.max()).rename(columns=lambda c: "Δ " + c)

# %%
show(plot_model_probabilities(table))

# %% [markdown]
# ## 5. Coefficient posterior
#
# The posterior of the coefficients of model 3 (both terms) under AR(1) residuals: a corner
# plot of the emcee draws (all walkers pooled), the traces of a few walkers, and the arviz
# summary (mean, sd, 95 % HDI, bulk/tail ESS, r_hat, MCSE).
#
# Read it as what it is: the posterior of λ **given the candidate's identified linear part**
# (for fixed A, B_f, C the reconstruction is affine in λ, `docs/method.md` §6). Model 3's linear part took up
# some of the damping (its first damping ratio is low in the modes table), so its α sits above
# 20 and the Coulomb coefficient's narrow interval need not contain 0: these intervals measure the
# noise, not the error of the linear part. That a redundant term does not help the fit is what
# the evidence of section 3 weighs.

# %%
posterior_ar1 = evidence["model 3"]["ar1"]
show(plot_posterior_pairs(posterior_ar1.posterior))
show(plot_traces(posterior_ar1.posterior))

# %%
posterior_ar1.summary

# %% [markdown]
# `bayesnsi select CONFIG --out DIR` saves these draws as `DIR/posterior/<candidate>.nc` (an arviz
# `DataTree` in netCDF4, listed in results.json `posterior_files`; `docs/posterior-files.md`). Written
# here the same way and read back as a notebook reads a run's output: xarray opens the file, arviz
# works on the tree. Without the honest intervals (notebook 04 writes them) the `posterior` group
# holds the sampler's draws, given the identified linear part.

# %%
import tempfile

import arviz_stats
import xarray as xr

from bayesnsi.io.posterior import NETCDF_ENGINE, write_posteriors

run_folder = tempfile.mkdtemp()
files = write_posteriors(run_folder, {name: by["ar1"] for name, by in evidence.items()})
tree = xr.open_datatree(f"{run_folder}/{files['model 3']}", engine=NETCDF_ENGINE)
arviz_stats.summary(tree, var_names=["coefficient"])

# %% [markdown]
# NSI estimates against the posterior means and 95 % intervals, for every candidate and
# likelihood:

# %%
rows = []
for name, per_likelihood in evidence.items():
    nsi_values = {c.term.name: c.value for c in results[name].coefficients}
    for likelihood, ev in per_likelihood.items():
        for term, mean, (low, high) in zip(ev.coefficient_names, ev.coefficient_mean, ev.ci95):
            rows.append(
                {
                    "candidate": name,
                    "likelihood": likelihood,
                    "term": term,
                    "exact": exact.get(term, 0.0),
                    "NSI": nsi_values[term],
                    "posterior mean": mean,
                    "hdi95 low": low,
                    "hdi95 high": high,
                }
            )
pd.DataFrame(rows).set_index(["candidate", "likelihood", "term"])

# %% [markdown]
# ## 6. Plain against evidence probabilities
#
# The plain ranking (paper Eq. 4) scores each candidate by its best-fit likelihood only: it
# has no penalty for coefficients the data do not need, and its probabilities carry no
# Monte-Carlo error. The evidence integrates the likelihood over the prior, so an unneeded
# coefficient costs an Occam factor, and its estimate comes with a standard error (the `_sd`
# columns propagate it to the probabilities).

# %%
table[["p_plain", "p_ar1", "p_ar1_sd", "p_white", "p_white_sd"]].map(lambda p: f"{p:.3g}")

# %%
best = {column: table[column].idxmax() for column in ("p_plain", "p_ar1", "p_white")}
print(f"true model: {case.true_model}")
for column, name in best.items():
    print(f"{column:8s} selects {name!r}")
