"""Adequacy of a stiff non-smooth element's true model: the sensor noise against the noise the model passes on.

On a 12-DOF chain with a clearance and 8 displacement channels, the true clearance model's
open-loop residual was 4.4x the sensor noise: ``select`` called it inadequate and widened its
interval to ±75 %. Its nonlinear input is computed from the noisy displacement, and the stiff element
turns that noise into a force that rings at the modes. This script simulates such a chain
(bayesnsi's own simulator: 12 unit masses, 4 kN/m springs, 3 N s/m dampers, a 1-40 Hz force at
DOF 3, a clearance spring of 4 kN/m at DOF 9 with its gap at one displacement std, 8 sensors with 2 %
noise) and prints, for the true model and for wrong ones (gap, DOF, none) that identify stably, the residual's ratio
to the sensor noise (the yardstick before) and to the noise the model passes on (the change of its
residual when fresh sensor noise is added: ``model_check.noise_ratio``, bayesnsi/checks/adequacy.py),
and the worst band of the band-by-band check.

    .venv/bin/python benchmarks/clearance_adequacy.py [--samples 50000] [--seed 0]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from types import SimpleNamespace  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import NSIOptions, Signals, identify  # noqa: E402
from bayesnsi.checks.adequacy import model_checks  # noqa: E402
from bayesnsi.exceptions import BayesNSIError  # noqa: E402
from bayesnsi.models import CandidateModel, Term  # noqa: E402
from bayesnsi.models.dictionary import clearance_expression  # noqa: E402
from bayesnsi.simulate import band_limited_gaussian, chain_system, simulate_response  # noqa: E402

FS, N_DOF, SHAKER, CLEARANCE_DOF, STIFFNESS = 200.0, 12, 3, 9, 4000.0
SENSORS = (1, 3, 5, 7, 9, 10, 11, 12)


def record(n_samples: int, seed: int):
    """The simulated chain with 2 % sensor noise, and the clearance's expression."""
    rng = np.random.default_rng(seed)
    M, C, K = chain_system([1.0] * N_DOF, [4000.0] * N_DOF, [3.0] * N_DOF)
    force = band_limited_gaussian(n_samples, FS, 20.0, rng, oversample=8, band_hz=(1.0, 40.0))
    linear = simulate_response(M, C, K, [SHAKER], force.fine, FS * 8, 8, [], [])
    gap = float(linear.displacement[:, CLEARANCE_DOF - 1].std())
    expression = clearance_expression(f"x{CLEARANCE_DOF}", gap)
    response = simulate_response(M, C, K, [SHAKER], force.fine, FS * 8, 8, [Term(expression, CLEARANCE_DOF)],
                                 [STIFFNESS])
    x = response.displacement[:, [d - 1 for d in SENSORS]]
    x = x + 0.02 * x.std(axis=0) * rng.standard_normal(x.shape)
    signals = Signals(force=response.force, displacement=x, fs=FS, input_dofs=(SHAKER,), output_dofs=SENSORS)
    return signals, gap


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=50_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    signals, gap = record(args.samples, args.seed)
    candidates = [CandidateModel("clearance @9 (true)", (Term(clearance_expression("x9", gap), 9),)),
                  CandidateModel("gap 0.5x @9", (Term(clearance_expression("x9", 0.5 * gap), 9),)),
                  CandidateModel("clearance @5", (Term(clearance_expression("x5", gap), 5),)),
                  CandidateModel("linear", ())]
    outcomes = []
    for candidate in candidates:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                result = identify(signals, candidate, NSIOptions(order=24, block_rows=30))
            except BayesNSIError as err:
                print(f"{candidate.name}: {type(err).__name__} ({str(err)[:90]}...)")
                continue
        if not result.coefficients:
            outcomes.append(SimpleNamespace(name=candidate.name, result=result, intervals=None))
            continue
        print(f"{candidate.name}: k = {result.coefficients[0].value:.4g} N/m (true at DOF 9: {STIFFNESS:g}), "
              f"{time.perf_counter() - t0:.1f} s")
        outcomes.append(SimpleNamespace(name=candidate.name, result=result, intervals=None))
    t0 = time.perf_counter()
    checks = model_checks(outcomes, signals, seed=args.seed)
    print(f"model_checks: {time.perf_counter() - t0:.1f} s ({args.samples} samples x {len(SENSORS)} channels)")
    print(f"\n{'candidate':>20} | {'resid/sensor noise':>18} {'resid/noise passed on':>21} | worst band")
    for name, check in checks.items():
        against_sensor = float(np.max(np.asarray(check.residual_rms) / np.asarray(check.noise_std)))
        band = "-" if check.band_ratio is None else (
            f"{check.band_ratio:.2f}x at {check.band_hz[0]:.3g}-{check.band_hz[1]:.3g} Hz (DOF {check.band_dof})")
        print(f"{name:>20} | {against_sensor:18.2f} {check.noise_ratio:21.2f} | {band}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
