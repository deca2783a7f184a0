"""Error of the loop's Coulomb case that the noise replicates cannot see (issue 15).

For each seed of ``coulomb-dof2`` simulated without sensor noise, the true model (20 v1|v1| at
DOF 1, sign(v2) = 1 N at DOF 2) is identified with ``upsample = R`` and 60 R block rows (the
loop's final model uses R = 4), and the mean and seed-to-seed sd of both coefficients are
printed per R (``--rows``: other block rows, per data-rate sample). Noise-free, every error is
one the noise replicates of :func:`bayesnsi.evidence.candidate_intervals` do not reproduce.

``--draws K`` asks what the replicates do see: per seed, with the loop's final settings (R = 4,
240 block rows), the true model is identified on the seed's clean response plus K fresh draws of
white noise at the seed's own noise level per channel (the force record held fixed), and the mean
and sd of those K estimates (the estimator's distribution given the force record) are printed
beside the estimate on the seed's data, the 16 noise replicates' sd and their mean shift (the
bias estimate of :mod:`bayesnsi.evidence.perturbation`).

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/calibration_coulomb_noise_free.py [--seeds 12]
[--factors 4 --rows 40 60 100] [--noise 2] [--draws 16 --seeds 4]``
"""

from __future__ import annotations

import argparse
import os
import warnings

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.simulate.undeclared import undeclared_case

TERMS = [("v1*abs(v1)", 1), ("sign(v2)", 2)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=12)
    parser.add_argument("--factors", type=int, nargs="+", default=[1, 2, 4, 8], help="upsampling factors R")
    parser.add_argument("--noise", type=float, default=0.0, help="sensor noise [%%] (the case's default: 2)")
    parser.add_argument("--rows", type=int, nargs="+", default=[60], help="block rows per data-rate sample")
    parser.add_argument("--draws", type=int, default=0, help="noise draws per seed given its force record")
    args = parser.parse_args()
    if args.draws:
        conditional(args.seeds, args.draws)
        return
    settings = [(factor, rows) for factor in args.factors for rows in args.rows]
    values = np.zeros((len(settings), args.seeds, len(TERMS)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in range(args.seeds):
            signals = undeclared_case("coulomb-dof2", seed=seed, noise_percent=args.noise).signals
            for k, (factor, rows) in enumerate(settings):
                nsi = NSIOptions(block_rows=rows * factor, order=4, upsample=factor)
                values[k, seed] = identify(signals, TERMS, nsi).coefficient_values
    print(f"coulomb-dof2 with {args.noise:g} % noise, seeds 0-{args.seeds - 1} (truth: 20, 1)")
    print("  R   block rows  alpha mean  alpha sd   sign(v2) mean  sign(v2) sd")
    for k, (factor, rows) in enumerate(settings):
        mean, sd = values[k].mean(axis=0), values[k].std(axis=0, ddof=1)
        print(f"  {factor:<3d} {rows * factor:10d} {mean[0]:11.3f} {sd[0]:9.3f}   {mean[1]:13.4f} {sd[1]:11.4f}")


def _noisy(clean, x_std, v_std, rng):
    """The clean record with fresh white noise of the given std per channel."""
    from dataclasses import replace

    return replace(clean, displacement=clean.displacement + rng.standard_normal(clean.displacement.shape) * x_std,
                   velocity=clean.velocity + rng.standard_normal(clean.velocity.shape) * v_std)


def conditional(seeds: int, draws: int) -> None:
    """Per seed: the estimator's mean and sd over fresh noise draws beside the noise replicates'."""
    from bayesnsi.evidence.perturbation import noise_replicates

    nsi = NSIOptions(block_rows=240, order=4, upsample=4)
    rng = np.random.default_rng(np.random.SeedSequence([15, draws]))
    print(f"coulomb-dof2, 2 % noise, {draws} noise draws per seed on its clean response (truth: 20, 1)")
    print("  seed  term          draws mean  draws sd   data estimate   replicates sd  replicates shift")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in range(seeds):
            reference = undeclared_case("coulomb-dof2", seed=seed).reference
            data, clean = reference.signals, reference.clean
            x_std = np.std(data.displacement - clean.displacement, axis=0)
            v_std = np.std(data.velocity - clean.velocity, axis=0)
            values = np.array([identify(_noisy(clean, x_std, v_std, rng), TERMS, nsi).coefficient_values
                               for _ in range(draws)])
            full = identify(data, TERMS, nsi)
            _, replicates, *_ = noise_replicates(full, data, nsi, 16, seed)
            shift = replicates.mean(axis=0) - full.coefficient_values
            for k, (expr, _) in enumerate(TERMS):
                print(f"  {seed:<5d} {expr:12s} {values[:, k].mean():11.4f} {values[:, k].std(ddof=1):9.4f}"
                      f" {full.coefficient_values[k]:15.4f} {replicates[:, k].std(ddof=1):14.4f}"
                      f" {shift[k]:17.4f}")


if __name__ == "__main__":
    main()
