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

``--pairing K`` asks whether a seed's own noise is a typical draw for its response: per seed, the
estimate on its own data, on its clean response plus each other seed's noise (rescaled to its
noise level per channel; ``--others``) and plus K draws from an independent stream
(``SeedSequence([seed, 777])``) are compared, as z = (estimate - mean over the other seeds' noise)
/ their sd; it prints the rms of z for the own noise and for the independent draws, and the
seed-to-seed sd of the estimates with the own noise and with the first independent draw.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/calibration_coulomb_noise_free.py [--seeds 12]
[--factors 4 --rows 40 60 100] [--noise 2] [--draws 16 --seeds 4] [--pairing 2 --seeds 20]``
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
    parser.add_argument("--pairing", type=int, default=0, help="independent noise draws per seed (pairing test)")
    parser.add_argument("--others", type=int, default=10, help="other seeds' noise per seed (pairing test)")
    args = parser.parse_args()
    if args.pairing:
        pairing(args.seeds, args.pairing, args.others)
        return
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


def pairing(seeds: int, draws: int, others: int) -> None:
    """Per seed: is its own noise a typical draw for its clean response? (sign(v2), the loop's settings)."""
    from dataclasses import replace

    from bayesnsi.simulate.undeclared import undeclared_cases

    nsi = NSIOptions(block_rows=240, order=4, upsample=4)
    n_cases = max(seeds, others + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cases = [c.reference for c in undeclared_cases("coulomb-dof2", list(range(n_cases)))]
        noise = [(r.signals.displacement - r.clean.displacement, r.signals.velocity - r.clean.velocity) for r in cases]

        def estimate(seed, disp_noise, vel_noise):
            clean, (own_d, own_v) = cases[seed].clean, noise[seed]
            disp = clean.displacement + disp_noise / disp_noise.std(axis=0) * own_d.std(axis=0)
            vel = clean.velocity + vel_noise / vel_noise.std(axis=0) * own_v.std(axis=0)
            return identify(replace(clean, displacement=disp, velocity=vel), TERMS, nsi).coefficient_values[1]

        print(f"coulomb-dof2, sign(v2) (truth 1): own noise against {others} other seeds' noise and {draws}"
              " independent draws")
        print("  seed   own      others mean  others sd   z own   z independent")
        z_own, z_ind, own_values, ind_values = [], [], [], []
        for seed in range(seeds):
            rng = np.random.default_rng(np.random.SeedSequence([seed, 777]))
            shape_d, shape_v = noise[seed][0].shape, noise[seed][1].shape
            independent = [estimate(seed, rng.standard_normal(shape_d), rng.standard_normal(shape_v))
                           for _ in range(draws)]
            own = estimate(seed, *noise[seed])
            reference = np.array([estimate(seed, *noise[o]) for o in range(n_cases) if o != seed][:others])
            mean, sd = reference.mean(), reference.std(ddof=1)
            z_own.append((own - mean) / sd)
            z_ind.extend((v - mean) / sd for v in independent)
            own_values.append(own)
            ind_values.append(independent[0])
            print(f"  {seed:<5d} {own:8.4f} {mean:12.4f} {sd:10.4f} {z_own[-1]:7.2f}   "
                  + " ".join(f"{(v - mean) / sd:.2f}" for v in independent), flush=True)
    rms = lambda z: float(np.sqrt(np.mean(np.square(z))))  # noqa: E731
    print(f"  rms z: own noise {rms(z_own):.2f} ({seeds} seeds), independent draws {rms(z_ind):.2f} ({len(z_ind)});"
          f" a t-distributed z with {others - 1} dof has rms {np.sqrt((others - 1) / (others - 3)):.2f}")
    print(f"  seed-to-seed sd of sign(v2): own noise {np.std(own_values, ddof=1):.4f},"
          f" independent noise {np.std(ind_values, ddof=1):.4f}")


if __name__ == "__main__":
    main()
