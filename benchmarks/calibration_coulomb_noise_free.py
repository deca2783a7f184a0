"""Error of the loop's Coulomb case that the noise replicates cannot see.

For each seed of ``coulomb-dof2`` simulated without sensor noise, the true model (20 v1|v1| at
DOF 1, sign(v2) = 1 N at DOF 2) is identified with ``upsample = R`` and 60 R block rows (the
loop's final model uses R = 4), and the mean and seed-to-seed sd of both coefficients are
printed per R (``--rows``: other block rows, per data-rate sample). Noise-free, every error is
one the noise replicates of :func:`bayesnsi.uncertainty.candidate_intervals` do not reproduce.

``--draws K`` asks what the replicates do see: per seed, with the loop's final settings (R = 4,
240 block rows), the true model is identified on the seed's clean response plus K fresh draws of
white noise at the seed's own noise level per channel (the force record held fixed), and the mean
and sd of those K estimates (the estimator's distribution given the force record) are printed
beside the estimate on the seed's data, the 16 noise replicates' sd and their mean shift (the
bias estimate of :mod:`bayesnsi.uncertainty.replicates`).

``--pairing K`` asks whether a seed's own noise is a typical draw for its response: per seed, the
estimate on its own data, on its clean response plus each other seed's noise (rescaled to its
noise level per channel; ``--others``) and plus K draws from an independent stream
(``SeedSequence([seed, 777])``) are compared, as z = (estimate - mean over the other seeds' noise)
/ their sd; it prints the rms of z for the own noise and for the independent draws, and the
seed-to-seed sd of the estimates with the own noise and with the first independent draw.

``--reference K`` measures the same against the estimator's own distribution given the force
record: per seed, K draws of white noise at the seed's noise level (``SeedSequence([seed, 4242])``)
on its clean response give the reference mean and sd; it prints z = (estimate - reference mean) /
reference sd for the seed's own data, for its own noise shifted by one sample and for one more
independent draw, and per coefficient how the interval's parts compare with that reference over
the seeds: the reference mean's error (rms, in reference sds), the clean estimate's, the 16 noise
replicates' sd over the reference sd, and their mean shift against the bias of the data's estimate
(own - reference mean) that it is meant to remove, and the 95 % coverage of the default interval
(replicates' centre and sd) beside that of one centred on the data's estimate less the seed's own
bias (reference mean - truth) with the reference sd.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/calibration_coulomb_noise_free.py [--seeds 12]
[--factors 4 --rows 40 60 100] [--noise 2] [--draws 16 --seeds 4] [--pairing 2 --seeds 20]
[--reference 20 --seeds 30]``
"""

from __future__ import annotations

import argparse
import math
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
    parser.add_argument("--reference", type=int, default=0, help="reference noise draws per seed (reference test)")
    parser.add_argument("--seed0", type=int, default=0, help="first seed")
    args = parser.parse_args()
    if args.reference:
        reference(list(range(args.seed0, args.seed0 + args.seeds)), args.reference)
        return
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
    from bayesnsi.uncertainty.replicates import noise_replicates

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


def reference(seeds: list[int], draws: int) -> None:
    """Per seed: own data, shifted own noise and a fresh draw against the estimator's distribution given the force."""
    from dataclasses import replace

    from scipy import stats

    from bayesnsi.simulate.undeclared import undeclared_cases
    from bayesnsi.uncertainty.replicates import noise_replicates

    nsi = NSIOptions(block_rows=240, order=4, upsample=4)
    truth = np.array([20.0, 1.0])
    print(f"coulomb-dof2, 2 % noise, seeds {seeds[0]}-{seeds[-1]}: estimates against {draws} noise draws on each"
          " seed's clean response (z, alpha / sign(v2))")
    print("  seed  z own          z own shifted  z independent")
    z = {"own": [], "shifted": [], "independent": []}
    parts: dict[str, list] = {k: [] for k in ("mean", "clean", "sd", "shift", "covered")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed, case in zip(seeds, undeclared_cases("coulomb-dof2", seeds)):
            clean, data = case.reference.clean, case.reference.signals
            e_x, e_v = data.displacement - clean.displacement, data.velocity - clean.velocity

            def estimate(n_x, n_v, clean=clean):
                noisy = replace(clean, displacement=clean.displacement + n_x, velocity=clean.velocity + n_v)
                return identify(noisy, TERMS, nsi).coefficient_values

            rng = np.random.default_rng(np.random.SeedSequence([seed, 4242]))
            x_std, v_std = e_x.std(axis=0), e_v.std(axis=0)
            independent = identify(_noisy(clean, x_std, v_std, rng), TERMS, nsi).coefficient_values
            ref = np.array([identify(_noisy(clean, x_std, v_std, rng), TERMS, nsi).coefficient_values
                            for _ in range(draws)])
            mean, sd = ref.mean(axis=0), ref.std(axis=0, ddof=1)
            full = identify(data, TERMS, nsi)
            own = full.coefficient_values
            shifted = estimate(np.roll(e_x, 1, axis=0), np.roll(e_v, 1, axis=0))
            for key, value in (("own", own), ("shifted", shifted), ("independent", independent)):
                z[key].append((value - mean) / sd)
            _, replicates, *_ = noise_replicates(full, data, nsi, 16, seed=seed)
            parts["mean"].append((mean - truth) / sd)
            parts["clean"].append((identify(clean, TERMS, nsi).coefficient_values - truth) / sd)
            parts["sd"].append(replicates.std(axis=0, ddof=1) / sd)
            parts["shift"].append(np.column_stack([replicates.mean(axis=0) - own, own - mean]))
            shift, q95 = replicates.mean(axis=0) - own, stats.t.ppf(0.975, len(replicates) - 1)
            parts["covered"].append([np.abs(own - shift - truth) <= q95 * replicates.std(axis=0, ddof=1)
                                     * np.sqrt(1 + 1 / len(replicates)),  # the default interval's centre and sd
                                     np.abs(own - (mean - truth) - truth) <= q95 * sd])  # knowing the seed's bias
            print(f"  {seed:<5d} " + "  ".join(f"{z[k][-1][0]:+5.2f} {z[k][-1][1]:+5.2f}" for k in z), flush=True)
    rms = lambda values: np.sqrt(np.mean(np.square(values), axis=0))  # noqa: E731
    t_rms = np.sqrt(1 + 1 / draws) * np.sqrt((draws - 1) / (draws - 3)) if draws > 3 else math.inf
    print(f"  rms z (alpha, sign(v2)): own {rms(z['own']).round(2)}, own shifted {rms(z['shifted']).round(2)},"
          f" independent {rms(z['independent']).round(2)}; {t_rms:.2f} expected")
    shift = np.array(parts["shift"])  # seeds x coefficient x (replicate shift, own - reference mean)
    for k, name in enumerate(("alpha", "sign(v2)")):
        sd_ratio = np.array(parts["sd"])[:, k]
        print(f"  {name}: reference mean - truth rms {rms(np.array(parts['mean'])[:, k]):.2f} sd,"
              f" clean estimate - truth rms {rms(np.array(parts['clean'])[:, k]):.2f} sd;"
              f" replicate sd / reference sd median {np.median(sd_ratio):.2f} (range {sd_ratio.min():.2f}-"
              f"{sd_ratio.max():.2f}); replicate shift mean {shift[:, k, 0].mean():+.4g} against"
              f" own - reference mean {shift[:, k, 1].mean():+.4g} (correlation"
              f" {np.corrcoef(shift[:, k, 0], shift[:, k, 1])[0, 1]:.2f})")
        covered = np.array(parts["covered"])[:, :, k].mean(axis=0)
        print(f"    95 % coverage: replicates' centre and sd {covered[0]:.0%}; centred on the data's estimate"
              f" less the seed's own bias (reference mean - truth), reference sd {covered[1]:.0%}")


if __name__ == "__main__":
    main()
