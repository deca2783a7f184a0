"""Error of the loop's Coulomb case that the noise replicates cannot see (issue 15).

For each seed of ``coulomb-dof2`` simulated without sensor noise, the true model (20 v1|v1| at
DOF 1, sign(v2) = 1 N at DOF 2) is identified with ``upsample = R`` and 60 R block rows (the
loop's final model uses R = 4), and the mean and seed-to-seed sd of both coefficients are
printed per R (``--rows``: other block rows, per data-rate sample). Noise-free, every error is
one the noise replicates of :func:`bayesnsi.evidence.candidate_intervals` do not reproduce.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/calibration_coulomb_noise_free.py [--seeds 12]
[--factors 4 --rows 40 60 100] [--noise 2]``
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
    args = parser.parse_args()
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


if __name__ == "__main__":
    main()
