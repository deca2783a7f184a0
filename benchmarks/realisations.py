"""All realisations of a periodic test at once against each alone (``Signals.realisations``, frequency route).

The simulated F-16-like ground vibration test of :func:`bayesnsi.simulate.gvt_records` (12 DOFs, 9
modes in the 1.5-15 Hz band, three accelerometers integrated line by line in 1-20 Hz, a joint with
friction ``F_f tanh((v7-v8)/0.002)`` and hardening ``k3 (x7-x8)**3`` between sensors 7 and 8; true
F_f = 0.1 N, k3 = 2e7 N/m³), four realisations of four steady periods per seed at one force level. The
true joint model is identified with the settings of ``workflows/gvt.py`` (order 20, 20 block rows, D
free) from each realisation alone and from the four joined (:func:`bayesnsi.signals.join_realisations`).
Printed per seed: k3 and F_f with their 95 % noise-replicate intervals (``[evidence] interval =
"noise"``: the identification repeated on copies with noise drawn from each realisation's period
scatter; the posterior part left out) and whether they hold the truth, the in-band modes against the
underlying linear structure (largest frequency error, median damping error) and the weighted line
misfit; then the mean absolute errors and the coverage over the seeds. The line "scatter" is the joint
estimate's 95 % interval from the scatter of the four single-realisation estimates (``[evidence]
interval = "segments"`` on a record of several realisations: noise and stochastic distortion).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/realisations.py
    ... benchmarks/realisations.py --seeds 0 1 2 --level 8 --replicates 8
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import NSIOptions, Signals  # noqa: E402
from bayesnsi.models import CandidateModel  # noqa: E402
from bayesnsi.nsi import identify, periodic_integration  # noqa: E402
from bayesnsi.options import EvidenceOptions  # noqa: E402
from bayesnsi.signals import join_realisations  # noqa: E402
from bayesnsi.simulate import GVT_BAND_HZ, GVT_SENSORS, GVT_SHAKER, gvt_records, gvt_structure  # noqa: E402
from bayesnsi.uncertainty.intervals import _noise_intervals  # noqa: E402

JOINT = CandidateModel.from_terms("joint 7-8", [("tanh((v7-v8)/0.002)", (7, 8)), ("(x7-x8)**3", (7, 8))])


def true_modes() -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios of the underlying linear structure inside the band."""
    M, C, K, _, _ = gvt_structure()
    n = len(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    poles = np.linalg.eigvals(A)
    poles = poles[poles.imag > 0]
    f = np.abs(poles) / (2 * np.pi)
    zeta = -poles.real / np.abs(poles)
    inside = (f >= GVT_BAND_HZ[0]) & (f <= GVT_BAND_HZ[1])
    order = np.argsort(f[inside])
    return f[inside][order], zeta[inside][order]


def signals(record) -> Signals:
    """Force and the accelerations integrated line by line (1-20 Hz) of one realisation."""
    velocity, displacement = periodic_integration(record.acceleration, record.fs, record.period, (1.0, 20.0))
    return Signals(force=record.force, displacement=displacement, velocity=velocity, fs=record.fs,
                   input_dofs=(GVT_SHAKER,), output_dofs=GVT_SENSORS, period=record.period, measured="acceleration")


def evaluate(data: Signals, nsi: NSIOptions, evidence: EvidenceOptions, truth) -> dict:
    """Identify the joint, its noise-replicate intervals and the mode errors."""
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = identify(data, JOINT, nsi)
        names = tuple(c.term.name for c in result.coefficients)
        centres = np.asarray(result.coefficient_values, dtype=float)
        nan = np.full(len(names), math.nan)
        intervals = _noise_intervals(result, data, evidence, nsi, (names, centres, nan, nan))
    f_true, z_true = truth
    f_id = np.array([m.frequency_hz for m in result.modes])
    z_id = np.array([m.damping_ratio for m in result.modes])
    nearest = np.array([int(np.argmin(np.abs(f_id - f))) for f in f_true])
    out = dict(
        values=centres, ci95=[p.ci95 for p in intervals.coefficients] if intervals else [(math.nan, math.nan)] * 2,
        df=float(np.max(np.abs(f_id[nearest] / f_true - 1))),
        dz=float(np.median(np.abs(z_id[nearest] / z_true - 1))),
        misfit=float(result.settings["line_misfit"]), seconds=time.perf_counter() - t0,
        spurious=sum("discarded" in str(w.message) or "reflected" in str(w.message) for w in caught),
    )
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--level", type=float, default=8.0, help="force rms [N]")
    parser.add_argument("--realisations", type=int, default=4)
    parser.add_argument("--replicates", type=int, default=8)
    args = parser.parse_args()
    _, _, _, _, coefficients = gvt_structure()
    friction, k3 = (float(c) for c in coefficients)
    truth = true_modes()
    nsi = NSIOptions(order=20, block_rows=20, zero_feedthrough=False, domain="frequency", band_hz=GVT_BAND_HZ)
    print(f"level {args.level:g} N, {args.realisations} realisations x 4 periods, {args.replicates} noise replicates; "
          f"truth F_f = {friction:g} N, k3 = {k3:.3g} N/m^3, {len(truth[0])} modes in the band")
    head = (f"{'seed':>4} {'data':>7} | {'k3 [1e7]':>8} {'95 % interval':>17} {'in':>3} | {'F_f [N]':>8} "
            f"{'95 % interval':>17} {'in':>3} | {'max df %':>8} {'med dz %':>8} | {'misfit':>6} {'pole!':>5} {'s':>5}")
    print(head)
    print("-" * len(head))
    rows: dict[str, list] = {"single": [], "joint": [], "segments": []}
    for seed in args.seeds:
        records = [signals(r) for r in gvt_records(levels=(args.level,), n_realisations=args.realisations, seed=seed)]
        evidence = EvidenceOptions(n_replicates=args.replicates, seed=seed)
        runs = [(f"r{k + 1}", "single", rec) for k, rec in enumerate(records)]
        runs.append(("all", "joint", join_realisations(records)))
        singles = []
        for label, kind, data in runs:
            try:
                row = evaluate(data, nsi, evidence, truth)
            except Exception as err:  # noqa: BLE001 - a benchmark reports a failed identification and goes on
                print(f"{seed:>4} {label:>7} | failed: {err}")
                continue
            rows[kind].append(row)
            if kind == "single":
                singles.append(row["values"])
            elif len(singles) == len(records):  # [evidence] interval = "segments": the realisations' scatter
                sd = np.sqrt(np.mean((np.array(singles) - row["values"]) ** 2, axis=0) / (len(singles) - 1))
                scatter = [(v - 1.96 * s, v + 1.96 * s) for v, s in zip(row["values"], sd)]
                rows["segments"].append(dict(row, ci95=scatter))
            (lo_f, hi_f), (lo_k, hi_k) = row["ci95"]
            f_val, k_val = row["values"]
            row["k_in"], row["f_in"] = lo_k <= k3 <= hi_k, lo_f <= friction <= hi_f
            print(f"{seed:>4} {label:>7} | {k_val / 1e7:8.3f} [{lo_k / 1e7:7.3f}, {hi_k / 1e7:7.3f}] "
                  f"{'yes' if row['k_in'] else 'no':>3} | {f_val:8.4f} [{lo_f:7.3f}, {hi_f:7.3f}] "
                  f"{'yes' if row['f_in'] else 'no':>3} | {100 * row['df']:8.2f} {100 * row['dz']:8.1f} | "
                  f"{row['misfit']:6.2f} {row['spurious']:5d} {row['seconds']:5.0f}")
            if rows["segments"] and rows["segments"][-1]["values"] is row["values"]:
                (lo_f, hi_f), (lo_k, hi_k) = rows["segments"][-1]["ci95"]
                print(f"{'':>4} {'scatter':>7} | {'':>8} [{lo_k / 1e7:7.3f}, {hi_k / 1e7:7.3f}] "
                      f"{'yes' if lo_k <= k3 <= hi_k else 'no':>3} | {'':>8} [{lo_f:7.3f}, {hi_f:7.3f}] "
                      f"{'yes' if lo_f <= friction <= hi_f else 'no':>3} |")
    for row in rows["segments"]:
        (lo_f, hi_f), (lo_k, hi_k) = row["ci95"]
        row["k_in"], row["f_in"] = lo_k <= k3 <= hi_k, lo_f <= friction <= hi_f
    print("\nsummary over the seeds: error of the estimates relative to the truth (mean, sd, mean absolute), "
          "95 % intervals holding the truth, mode errors against the underlying linear structure")
    for kind, found in rows.items():
        if not found:
            continue
        k_rel = np.array([r["values"][1] / k3 - 1 for r in found])
        f_rel = np.array([r["values"][0] / friction - 1 for r in found])
        width = np.median([(r["ci95"][1][1] - r["ci95"][1][0]) / k3 for r in found])
        sd = (lambda e: 100 * e.std(ddof=1) if len(e) > 1 else 0.0)  # noqa: E731
        df, dz = (100 * np.mean([r[key] for r in found]) for key in ("df", "dz"))
        print(f"{kind:>7}: k3 {100 * k_rel.mean():+6.1f} % sd {sd(k_rel):5.1f} % "
              f"|e| {100 * np.abs(k_rel).mean():5.1f} % (95 % width {100 * width:5.1f} %), "
              f"covered {sum(r['k_in'] for r in found)}/{len(found)}; "
              f"F_f {100 * f_rel.mean():+6.1f} % sd {sd(f_rel):5.1f} % |e| {100 * np.abs(f_rel).mean():5.1f} %, "
              f"covered {sum(r['f_in'] for r in found)}/{len(found)}; max df {df:.2f} %, median dzeta {dz:.1f} %; "
              f"{np.mean([r['seconds'] for r in found]):.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
