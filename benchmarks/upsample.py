"""Effect of identifying on an upsampled grid on the negative-stiffness twin (SPEC 8.3 and 10).

The twin's friction α1·sign(ż)·g(z) is discontinuous; sampled at 512 Hz, a sampled model
mis-places its switches and the superset (Table 8 model 4, with an extra α3·sign(ż)) absorbs
the error. For each seed this identifies models 2 (true) and 4 with ``identify`` with
``NSIOptions(upsample=R)`` (block rows as listed in SETTINGS), and prints the coefficient errors
of model 2, its open-loop NRMSE, model 4's spurious α3, the log Bayes factor of model 4 over
model 2 under the AR(1) evidence (positive: the superset wins; ``--residual``) and the
identification time.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/upsample.py [--seeds 5] [--noise 1]``
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from bayesnsi import EvidenceOptions, NSIOptions, identify
from bayesnsi.evidence import candidate_evidence
from bayesnsi.simulate import simulate_cases

SETTINGS = ((1, 40), (2, 80), (4, 80))  # (upsample R, block rows on the fine grid)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--noise", type=float, default=1.0, help="output noise [%%]")
    parser.add_argument("--no-evidence", action="store_true")
    parser.add_argument("--residual", default="innovations", choices=("innovations", "reconstruction"),
                        help="residual of the evidence (default innovations)")
    parser.add_argument("--bd-method", default="output-error", choices=("output-error", "prediction-error"))
    parser.add_argument("--factors", type=int, nargs="+", default=[r for r, _ in SETTINGS], help="upsampling factors R")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cases = simulate_cases("negative-stiffness", range(args.seeds), noise_percent=args.noise)
    options = EvidenceOptions(residual=args.residual, likelihood="ar1", compare=(), n_walkers=32, n_steps=800,
                              n_burn=200)
    print(f"negative-stiffness twin, 140 s at 512 Hz, {args.noise:g} % noise, {args.seeds} seeds, order 2, "
          f"band 5-20 Hz, B/D {args.bd_method}, evidence residual {args.residual}")
    print(f"{'seed':>4} {'R':>2} {'i':>4} | model 2 error %: {'k2':>6} {'k3':>6} {'a1':>6} {'a2':>6} | "
          f"{'NRMSE':>7} | {'a3 [N]':>8} | {'log BF 4:2':>10} | {'s':>5}")
    for case in cases:
        for factor, rows in [(r, i) for r, i in SETTINGS if r in args.factors]:
            start = time.perf_counter()
            nsi = NSIOptions(block_rows=rows, order=2, band_hz=(5.0, 20.0), upsample=factor, bd_method=args.bd_method)
            fits = {name: identify(case.signals, case.candidate(name), nsi) for name in ("model 2", "model 4")}
            seconds = (time.perf_counter() - start) / 2
            err = 100 * (fits["model 2"].coefficient_values / case.true_coefficients - 1)
            nrmse = fits["model 2"].reconstruct(case.signals).nrmse
            alpha3 = fits["model 4"].coefficient_values[-1]
            bf = float("nan")
            if not args.no_evidence:
                z = {
                    name: candidate_evidence(fit, case.signals, options, np.random.SeedSequence(1), warn=False)
                    for name, fit in fits.items()
                }
                bf = z["model 4"]["ar1"].log_evidence - z["model 2"]["ar1"].log_evidence
            print(f"{case.seed:>4} {factor:>2} {rows:>4} |                  "
                  f"{err[0]:>6.2f} {err[1]:>6.2f} {err[2]:>6.2f} {err[3]:>6.2f} | "
                  f"{nrmse:>7.5f} | {alpha3:>8.5f} | {bf:>10.1f} | {seconds:>5.1f}", flush=True)


if __name__ == "__main__":
    main()
