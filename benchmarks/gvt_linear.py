"""The linear part on the simulated ground vibration test against the nonparametric FRF.

Per level of :func:`bayesnsi.simulate.gvt_records` (realisations 0 and 1, 4 periods each): the
linear model of the frequency route (order ``--order``, band 1.5-15 Hz, D free) identified on
realisation 0 and the nonparametric period-averaged FRF of realisation 0 (Y/U on its excited
lines) both predict realisation 1 on its excited lines in the band, in accelerations. Columns:

- ``model pred`` / ``FRF pred``: relative rms prediction error of realisation 1, and their ratio
  (target: model within 1.2x the nonparametric FRF);
- ``est misfit / (n+d)``: the model's misfit on the estimation lines over the noise-plus-distortion
  level there (M · var(G_BLA) · |U|² from the two realisations; target: within 1.5x; with two
  realisations that level is a one-degree-of-freedom estimate per line, so its sum is rough).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/gvt_linear.py
    ... benchmarks/gvt_linear.py --order 18 20 24 [--seed 1] [--dictionary]

``--dictionary`` also identifies each effect of the default dictionary alone (the third
target: none may fail because of a pole outside the band).

Measured (2026-11-26, with the linear model refined from several subspace starts, block rows r,
1.25r, 1.5r, 2r, the best kept): order 20 (the workflow's) meets both targets at every level on
seeds 0 and 1 - prediction 0.91 / 0.88 / 0.87 (seed 1: 0.87 / 0.92 / 0.87) of the FRF's error and
misfit 1.07 / 0.97 / 0.75 (1.25 / 0.91 / 0.98) of the noise-plus-distortion level at 0.1 / 1 / 8 N.
From one start (block rows 20) order 20 reached 2.15 / 1.49 / 0.83 and misfit 2.94 / 1.86 / 0.77:
the refinement of a many-mode model ends in the local minimum its start leads to. Order 18 misses
at 0.1 N (2.65, 1.47 on seed 1), order 24 on seed 1 (2.35 at 0.1 N, 1.26 at 1 N). With
``--order 20 --dictionary`` (seed 0) all 28 default-dictionary effects identify at every level; at
8 N two of them have an unstable pole outside the band, reflected with a warning, none fails.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import NSIOptions, Signals  # noqa: E402
from bayesnsi.exceptions import BayesNSIError  # noqa: E402
from bayesnsi.models import CandidateModel, effect_dictionary  # noqa: E402
from bayesnsi.nsi import best_linear_approximation, identify, period_spectra, periodic_integration  # noqa: E402
from bayesnsi.simulate import GVT_BAND_HZ, GVT_SENSORS, GVT_SHAKER, gvt_records  # noqa: E402

LEVELS = (0.1, 1.0, 8.0)


def signals(record) -> Signals:
    velocity, displacement = periodic_integration(record.acceleration, record.fs, record.period, (1.0, 20.0))
    return Signals(force=record.force, displacement=displacement, velocity=velocity, fs=record.fs,
                   input_dofs=(GVT_SHAKER,), output_dofs=GVT_SENSORS, period=record.period)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--order", type=int, nargs="+", default=[20])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dictionary", action="store_true",
                        help="also identify every default-dictionary candidate (one effect) at each level and order")
    args = parser.parse_args()
    records = gvt_records(levels=LEVELS, n_realisations=2, seed=args.seed)
    header = ("level N", "order", "model pred", "FRF pred", "ratio", "est misfit / (n+d)")
    print(" | ".join(f"{h:>{w}}" for h, w in zip(header, (7, 5, 10, 8, 5, 18))))
    for level in LEVELS:
        est, val = (signals(r) for r in records if r.level == level)
        s_est, s_val = period_spectra(est), period_spectra(val)
        lines = s_val.lines(GVT_BAND_HZ)
        lines_est = s_est.lines(GVT_BAND_HZ)
        freqs = s_val.freqs_hz[lines]
        omega2 = (2 * np.pi * freqs) ** 2  # accelerations: A = -ω² X
        frf_np = s_est.response[lines] / s_est.force[lines]  # nonparametric FRF of realisation 0
        y_val = s_val.response[lines] * omega2[:, None]
        pred_np = frf_np * s_val.force[lines] * omega2[:, None]
        bla = best_linear_approximation([est, val])
        w2 = ((2 * np.pi * bla.freqs_hz) ** 2)[:, None]
        level_nd = 2 * bla.total_var * np.abs(s_est.force[lines_est]) ** 2 * w2**2
        for order in args.order:
            options = NSIOptions(domain="frequency", order=order, band_hz=GVT_BAND_HZ, block_rows=20,
                                 zero_feedthrough=False)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = identify(est, None, options)
            h_val = model.underlying_frf(freqs)[:, :, 0]
            pred_model = h_val * s_val.force[lines] * omega2[:, None]
            err_model = np.linalg.norm(y_val - pred_model) / np.linalg.norm(y_val)
            err_np = np.linalg.norm(y_val - pred_np) / np.linalg.norm(y_val)
            h_est = model.underlying_frf(bla.freqs_hz)[:, :, 0]
            res_est = (s_est.response[lines_est] - h_est * s_est.force[lines_est]) * w2
            misfit = np.sum(np.abs(res_est) ** 2) / np.sum(level_nd)
            print(f"{level:7g} | {order:5d} | {err_model:10.4f} | {err_np:8.4f} | {err_model / err_np:5.2f} | "
                  f"{np.sqrt(misfit):18.2f}")
            if args.dictionary:
                print("        " + dictionary_check(est, options))


def dictionary_check(est: Signals, options: NSIOptions) -> str:
    """Identify each default-dictionary effect alone; count failures and the poles reflected outside the band."""
    failed, reflected = [], 0
    effects = effect_dictionary(GVT_SENSORS)
    for effect in effects:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                result = identify(est, CandidateModel(name=effect.term.name, terms=(effect.term,)), options)
            except BayesNSIError as err:
                failed.append(f"{effect.term.name}: {type(err).__name__}")
                continue
        lo, hi = GVT_BAND_HZ
        reflected += any(not lo <= f <= hi for f in result.settings.get("reflected_poles_hz", []))
    return (f"default dictionary: {len(effects) - len(failed)}/{len(effects)} identified, {reflected} with an unstable "
            f"pole outside the band reflected" + (f"; failed: {', '.join(failed)}" if failed else ""))


if __name__ == "__main__":
    main()
