"""Benchmark of the evidence of one candidate (SPEC 6): cost and accuracy.

For N = 1e4, 1e5, 1e6 samples, q = 1..3 coefficients, l = 2 output channels, white and exact
AR(1) likelihoods, it times :func:`bayesnsi.evidence.marginal_evidence` at default settings
(sufficient statistics, emcee, bridge sampling, Laplace, arviz summary) on a synthetic affine
reconstruction, and compares the bridge estimate with the exact evidence by quadrature
(computed separately, not timed). Target: < 5 s per candidate whatever N.

Run::

    python benchmarks/evidence.py                 # the table
    python benchmarks/evidence.py --quick         # N = 1e4 only
    python benchmarks/evidence.py --calibration 20  # bridge error / SE over 20 datasets
"""

from __future__ import annotations

import argparse
import platform
import time
import warnings

import numpy as np
from scipy.signal import lfilter

from bayesnsi.evidence import (
    CoefficientPrior,
    NoisePrior,
    Priors,
    closed_form_log_evidence,
    marginal_evidence,
    sufficient_statistics,
)
from bayesnsi.exceptions import ConvergenceWarning
from bayesnsi.nsi import AffineReconstruction


def synthetic(n_samples: int, n_channels: int, q: int, rng, sigma: float = 0.5, rho: float = 0.0):
    """Affine reconstruction with smooth random signatures and (AR(1)) Gaussian noise."""
    g = rng.standard_normal((n_samples, n_channels, q))
    g = lfilter([1.0], [1.0, -0.95], g, axis=0)  # low-pass, like structural responses
    lam = rng.standard_normal(q)
    noise = sigma * rng.standard_normal((n_samples, n_channels))
    if rho:
        noise[0] /= np.sqrt(1 - rho**2)
        noise = lfilter([1.0], [1.0, -rho], noise, axis=0)
    baseline = rng.standard_normal((n_samples, n_channels))
    measured = baseline + g @ lam + noise
    flat_g = g.reshape(-1, q)
    estimate = np.linalg.solve(flat_g.T @ flat_g, flat_g.T @ (measured - baseline).reshape(-1))
    return AffineReconstruction(measured, baseline, g, estimate, tuple(f"k{i}" for i in range(q)))


def priors_for(affine, scale: float = 3.0) -> Priors:
    q = affine.signatures.shape[2]
    return Priors(CoefficientPrior(affine.names, np.full(q, scale)), NoisePrior.from_std(affine.measured.std(axis=0)))


def one(n_samples, q, likelihood, seed, n_channels=2):
    rng = np.random.default_rng(seed)
    affine = synthetic(n_samples, n_channels, q, rng, rho=0.8 if likelihood == "ar1" else 0.0)
    priors = priors_for(affine)
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        result = marginal_evidence(affine, priors, likelihood, rng=rng, closed_form=False)
    elapsed = time.perf_counter() - t0
    t0 = time.perf_counter()
    stats = sufficient_statistics(affine, ar_order=1 if likelihood == "ar1" else 0)
    exact = closed_form_log_evidence(stats, priors, likelihood)
    t_exact = time.perf_counter() - t0
    return result, elapsed, exact, t_exact, len(caught)


def table(sizes, qs, likelihoods, seed):
    head = (
        f"{'lik':>5} {'N':>8} {'q':>2} | {'total s':>7} {'stats':>6} {'emcee':>6} {'bridge':>6} {'arviz':>6} | "
        f"{'|br-ex|':>8} {'SE':>7} {'|la-ex|':>8} {'exact s':>7} | {'rhat':>6} {'ESS':>6} {'warn':>4}"
    )
    print(head)
    print("-" * len(head))
    for likelihood in likelihoods:
        for n in sizes:
            for q in qs:
                r, elapsed, exact, t_exact, n_warn = one(n, q, likelihood, seed + q)
                s = r.settings
                print(
                    f"{likelihood:>5} {n:>8.0e} {q:>2} | {elapsed:7.2f} {s['time_statistics_s']:6.2f} "
                    f"{s['time_sampling_s']:6.2f} {s['time_evidence_s']:6.2f} {s['time_summary_s']:6.2f} | "
                    f"{abs(r.log_evidence - exact):8.4f} {r.log_evidence_se:7.4f} "
                    f"{abs(r.laplace_log_evidence - exact):8.4f} {t_exact:7.2f} | {r.rhat_max:6.4f} "
                    f"{r.ess_min:6.0f} {n_warn:>4}"
                )


def calibration(n_datasets, seed, n_samples=10_000, q=2):
    for likelihood in ("white", "ar1"):
        errors, ses = [], []
        for k in range(n_datasets):
            r, _, exact, _, _ = one(n_samples, q, likelihood, seed + 1000 + k)
            errors.append(r.log_evidence - exact)
            ses.append(r.log_evidence_se)
        errors, ses = np.array(errors), np.array(ses)
        print(
            f"{likelihood}: N = {n_samples}, q = {q}, {n_datasets} datasets: bridge - exact RMSE = "
            f"{np.sqrt(np.mean(errors**2)):.4f} nat, max |err| = {np.max(np.abs(errors)):.4f}, median SE = "
            f"{np.median(ses):.4f}, |err| <= 2 SE in {np.mean(np.abs(errors) <= 2 * ses):.0%}"
        )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e4 only")
    parser.add_argument("--calibration", type=int, default=0, help="datasets for the error/SE study")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}; l = 2 channels")
    sizes = [10_000] if args.quick else [10_000, 100_000, 1_000_000]
    table(sizes, [1, 2, 3], ["white", "ar1"], args.seed)
    if args.calibration:
        calibration(args.calibration, args.seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
