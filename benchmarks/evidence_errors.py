"""Do the evidence's stated Monte-Carlo errors hold? Error against the exact value over seeds, per path.

Paths: ``collapsed`` (the default: noise parameters integrated out, emcee over the coefficients,
bridge sampling), ``joint`` (``collapse=False``: emcee over every parameter ``(λ, log σ, ρ)``, bridge
sampling; what runs for AR(P), P > 1) and ``laplace`` (an approximation: no Monte-Carlo error; its
error against the exact value alone is printed). The exact value is the quadrature over the
coefficients of the collapsed integrand (:func:`bayesnsi.evidence.quadrature_log_evidence`), any
number of channels.

Cases: the two-DOF paper case (models 1 and 2, 1 % noise, the case's recommended NSI settings; one
simulation per seed, each model's evidence with its own sampler seed) and a 16-channel affine
stand-in (two smooth signatures, white or AR(1) noise with ρ = 0.8; a new data set per seed). Columns:
runs, rms error, rms stated error, rms z = rms(error / stated error), the largest |z|, the runs beyond
3 stated errors, mean seconds per run.

Run::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/evidence_errors.py          # 10 seeds
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/evidence_errors.py --seeds 20 --duration 1000
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
    candidate_affine,
    candidate_priors,
    evidence_from_statistics,
    quadrature_log_evidence,
    sufficient_statistics,
)
from bayesnsi.exceptions import ConvergenceWarning
from bayesnsi.nsi import AffineReconstruction, identify
from bayesnsi.options import EvidenceOptions
from bayesnsi.simulate.reference import case_setup, run_setup

PATHS = {"collapsed": {"collapse": True}, "joint": {"collapse": False}}


def two_dof(seeds, duration: float):
    """(label, statistics, priors) of models 1 and 2 of the two-DOF case, per seed."""
    cases = run_setup(case_setup("two-dof", duration=duration), list(seeds), 1.0)
    for case in cases:
        for index in (0, 1):
            candidate = case.candidates[index]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # identification notes are not what is measured here
                result = identify(case.signals, candidate, case.recommended)
            affine = candidate_affine(result, case.signals, "innovations")
            priors = candidate_priors(result, case.signals, affine, EvidenceOptions(), candidate)
            yield f"two-DOF model {index + 1}", sufficient_statistics(affine, ar_order=1), priors


def stand_in(seed: int, n_channels: int, likelihood: str, n_samples: int = 10_000):
    """Affine reconstruction with two smooth signatures and white or AR(1) (ρ = 0.8) noise, its statistics, priors."""
    rng = np.random.default_rng(seed)
    g = lfilter([1.0], [1.0, -0.95], rng.standard_normal((n_samples, n_channels, 2)), axis=0)
    noise = 0.5 * rng.standard_normal((n_samples, n_channels))
    if likelihood == "ar1":
        noise[0] /= np.sqrt(1 - 0.8**2)
        noise = lfilter([1.0], [1.0, -0.8], noise, axis=0)
    baseline = rng.standard_normal((n_samples, n_channels))
    measured = baseline + g @ rng.standard_normal(2) + noise
    flat = g.reshape(-1, 2)
    estimate = np.linalg.solve(flat.T @ flat, flat.T @ (measured - baseline).reshape(-1))
    affine = AffineReconstruction(measured, baseline, g, estimate, ("k0", "k1"))
    priors = Priors(CoefficientPrior(affine.names, np.full(2, 3.0)), NoisePrior.from_std(measured.std(axis=0)))
    return sufficient_statistics(affine, ar_order=1), priors


def measure(stats, priors, likelihood: str, seed_sequence, rows: dict, label: str) -> None:
    """Each path's error against the exact value, its stated error and its time, appended to ``rows``."""
    exact = quadrature_log_evidence(stats, priors, likelihood)
    laplace = None
    for (path, kwargs), child in zip(PATHS.items(), seed_sequence.spawn(len(PATHS))):
        n_params = stats.n_coefficients + (0 if kwargs["collapse"] else stats.n_channels * (1 + (likelihood == "ar1")))
        walkers = max(32, 2 * n_params + 2)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            result = evidence_from_statistics(stats, priors, likelihood, rng=np.random.default_rng(child),
                                              n_walkers=walkers + walkers % 2, closed_form=False, **kwargs)
        seconds = time.perf_counter() - t0
        rows.setdefault((label, likelihood, path), []).append(
            (result.log_evidence - exact.log_evidence, result.log_evidence_se, seconds))
        laplace = result
    # the Laplace approximation: its error against the exact value
    rows.setdefault((label, likelihood, "laplace"), []).append(
        (laplace.laplace_log_evidence - exact.log_evidence, np.nan, 0.0))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--duration", type=float, default=100.0, help="two-DOF record length [s] at 100 Hz")
    parser.add_argument("--channels", type=int, default=16, help="channels of the affine stand-in")
    parser.add_argument("--paths", nargs="+", choices=sorted(PATHS), default=sorted(PATHS), help="sampled paths run")
    args = parser.parse_args(argv)
    for path in set(PATHS) - set(args.paths):
        del PATHS[path]
    print(f"python {platform.python_version()}, numpy {np.__version__}; {args.seeds} seeds; two-DOF "
          f"{args.duration:g} s at 100 Hz; stand-in {args.channels} channels, 1e4 samples")
    rows: dict = {}
    root = np.random.SeedSequence(2026)
    cases = list(two_dof(range(args.seeds), args.duration))
    for j, likelihood in enumerate(("white", "ar1")):
        for k, (label, stats, priors) in enumerate(cases):
            measure(stats, priors, likelihood, np.random.SeedSequence([2026, j, k]), rows, label)
        for seed in range(args.seeds):
            stats, priors = stand_in(1000 + seed, args.channels, likelihood)
            measure(stats, priors, likelihood, root.spawn(1)[0], rows, f"stand-in, {args.channels} channels")
    head = (f"{'case':>24} {'lik':>5} {'path':>9} | {'runs':>4} {'rms err':>8} {'rms SE':>8} {'rms z':>6} "
            f"{'max|z|':>6} {'>3 SE':>5} {'s/run':>6}")
    print(head)
    print("-" * len(head))
    for (label, likelihood, path), values in rows.items():
        err, se, seconds = (np.array(v) for v in zip(*values))
        if path == "laplace":  # an approximation: no Monte-Carlo error to divide by
            print(f"{label:>24} {likelihood:>5} {path:>9} | {len(err):4d} {np.sqrt(np.mean(err**2)):8.5f} "
                  f"{'approx.':>8} {'-':>6} {'-':>6} {'-':>5} {'-':>6}")
            continue
        z = err / se
        print(f"{label:>24} {likelihood:>5} {path:>9} | {len(err):4d} {np.sqrt(np.mean(err**2)):8.5f} "
              f"{np.sqrt(np.mean(se**2)):8.5f} {np.sqrt(np.mean(z**2)):6.2f} {np.max(np.abs(z)):6.2f} "
              f"{int(np.sum(np.abs(z) > 3)):5d} {np.mean(seconds):6.2f}")
    for path in PATHS:  # pooled over the cases
        z = np.concatenate([np.array([e / s for e, s, _ in v]) for (_, _, p), v in rows.items() if p == path])
        print(f"{'all cases':>24} {'both':>5} {path:>9} | {z.size:4d} {'':>8} {'':>8} {np.sqrt(np.mean(z**2)):6.2f} "
              f"{np.max(np.abs(z)):6.2f} {int(np.sum(np.abs(z) > 3)):5d}")
    print("laplace: an approximation (no Monte-Carlo error); its error is its distance to the exact value")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
