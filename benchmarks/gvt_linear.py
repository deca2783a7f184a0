"""The linear part on the simulated ground vibration test against the nonparametric FRF (issue 17 item 1).

Per level of :func:`bayesnsi.simulate.gvt_records` (realisations 0 and 1, 4 periods each): the
linear model of the frequency route (order ``--order``, band 1.5-15 Hz, D free) identified on
realisation 0 and the nonparametric period-averaged FRF of realisation 0 (Y/U on its excited
lines) both predict realisation 1 on its excited lines in the band, in accelerations. Columns:

- ``model pred`` / ``FRF pred``: relative rms prediction error of realisation 1, and their ratio
  (issue target: model within 1.2x the nonparametric FRF);
- ``est misfit / (n+d)``: the model's misfit on the estimation lines over the noise-plus-distortion
  level there (M · var(G_BLA) · |U|² from the two realisations; issue target: within 1.5x; with two
  realisations that level is a one-degree-of-freedom estimate per line, so its sum is rough).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/gvt_linear.py
    ... benchmarks/gvt_linear.py --order 18 20 24

Measured (last command, seed 0): at 1 N and 8 N the model of order 18 or 20 predicts the other
realisation at 0.87-0.95x the nonparametric FRF's error and fits the estimation lines at
0.95-1.17x the noise-plus-distortion level (both targets met); at 0.1 N (distortion near the
noise) orders 18/20 are 2.2-2.9x the FRF (misfit 2.9-4.2x) and only order 24 meets them (0.83,
0.88), which then misses at 1 N (1.33, 1.64): no single order meets item 1 at every level yet.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import NSIOptions, Signals  # noqa: E402
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


if __name__ == "__main__":
    main()
