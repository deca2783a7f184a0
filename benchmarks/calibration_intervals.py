"""Calibration of the coefficient and modal intervals on simulated reference cases.

For each case (``two-dof``: paper settings, true model 1 = 20 v1|v1|; ``three-dof``: cubic spring
between DOFs 1 and 2; ``negative-stiffness``: the twin of SPEC 8.3, true model 2) and each seed
it simulates the case at its default noise, identifies the true model with the case's
recommended settings, computes the evidence exactly as ``bayesnsi select`` does
(:func:`bayesnsi.evidence.candidate_evidence`, ``EvidenceOptions()`` defaults: AR(1), innovations)
and the intervals (:func:`bayesnsi.uncertainty.candidate_intervals`, default ``interval =
"auto"``: 16 copies of the record with added sensor noise - none of these cases holds the Coulomb
friction for which it draws records of the identified model instead - Student-t intervals about the
bias-corrected estimate, stretched to hold the reported one; ``--interval segments`` gives the
sub-record intervals). It prints, per coefficient and per modal parameter (natural frequency,
damping ratio against the simulator's exact modes):

* the mean estimate, its bias over the seed-to-seed sd of the estimates, the same for the
  bias-corrected centre (``estimate - bias``), and the seed-to-seed sd;
* coverage of the truth by the 50 % and 95 % intervals, and by the posterior's 95 %
  interval alone (conditional on the identified linear part; the old ``ci95``);
* mean width of the 95 % interval against the width implied by the scatter, 2 x 1.96 x sd
  (target: a ratio of at most 1.5 and coverage 90-98 % / 40-60 %).

The reliability of the posterior model probabilities is the study of ``benchmarks/calibration.py``.

Run::

    nice .venv/bin/python benchmarks/calibration_intervals.py                # 100 seeds per case, 2 workers
    .venv/bin/python benchmarks/calibration_intervals.py --quick             # 6 seeds per case
    .venv/bin/python benchmarks/calibration_intervals.py --cases two-dof --seeds 200 --json out.json
    .venv/bin/python benchmarks/calibration_intervals.py --cases negative-stiffness --tables out.json
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from concurrent.futures import ProcessPoolExecutor, as_completed  # noqa: E402

import numpy as np  # noqa: E402

CASE_NAMES = ("two-dof", "three-dof", "negative-stiffness")


def one_seed(case_name: str, seed: int, opts) -> dict:
    """Simulate one seed, identify the true model, its evidence and intervals."""
    from bayesnsi import identify, simulate_case
    from bayesnsi.evidence import candidate_evidence
    from bayesnsi.exceptions import BayesNSIError
    from bayesnsi.uncertainty import candidate_intervals

    t0 = time.perf_counter()
    case = simulate_case(case_name, seed=seed)
    cand = next(c for c in case.candidates if c.name == case.true_model)
    out: dict = {"case": case_name, "seed": seed}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            result = identify(case.signals, cand, case.recommended)
            ev = candidate_evidence(result, case.signals, opts, np.random.SeedSequence([seed, 15]), cand)
            primary = ev[opts.likelihood]
            iv = candidate_intervals(result, case.signals, primary, opts, case.recommended)
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            out["error"] = f"{type(err).__name__}: {err}"
            return out
    exact_f, exact_z = case.exact_frequencies_hz, case.exact_damping_ratios
    params = []
    truth = list(case.true_coefficients)
    for k, p in enumerate(iv.coefficients):
        params.append({**p.to_dict(), "truth": float(truth[k]), "posterior_ci95": [float(v) for v in primary.ci95[k]],
                       "nsi": float(result.coefficient_values[k])})
    for kind, items, exact in (("f", iv.frequencies, exact_f), ("zeta", iv.damping_ratios, exact_z)):
        for k, p in enumerate(items):
            nearest = int(np.argmin(np.abs(exact_f - result.modes[k].frequency_hz)))
            params.append({**p.to_dict(), "name": f"{kind}{nearest + 1}", "truth": float(exact[nearest]),
                           "posterior_ci95": None})
    out.update(method=iv.method, n_segments=iv.n_segments, params=params, seconds=time.perf_counter() - t0)
    return out


def summarise(records: list[dict]) -> list[dict]:
    """Per parameter: bias, scatter, coverage and width ratio over the seeds."""
    ok = [r for r in records if "params" in r]
    names = []
    for r in ok:
        for p in r["params"]:
            if p["name"] not in names:
                names.append(p["name"])
    rows = []
    for name in names:
        ps = [p for r in ok for p in r["params"] if p["name"] == name]
        est = np.array([p["estimate"] for p in ps])
        truth = ps[0]["truth"]
        lo95, hi95 = np.array([p["ci95"] for p in ps]).T
        lo50, hi50 = np.array([p["ci50"] for p in ps]).T
        sd = float(np.std(est, ddof=1)) if len(est) > 1 else float("nan")
        bias = np.array([p.get("bias", float("nan")) for p in ps], dtype=float)
        centre = est - np.where(np.isfinite(bias), bias, 0.0)
        post = [p["posterior_ci95"] for p in ps if p["posterior_ci95"] is not None]
        post_cov = float(np.mean([lo <= truth <= hi for lo, hi in post])) if post else float("nan")
        rows.append({
            "name": name, "n": len(ps), "truth": truth, "mean": float(est.mean()), "bias": float(est.mean() - truth),
            "centre_bias": float(centre.mean() - truth),
            "sd": sd, "cov50": float(np.mean((lo50 <= truth) & (truth <= hi50))),
            "cov95": float(np.mean((lo95 <= truth) & (truth <= hi95))), "cov95_posterior": post_cov,
            "width95": float(np.mean(hi95 - lo95)), "width_ratio": float(np.mean(hi95 - lo95) / (2 * 1.96 * sd)),
        })
    return rows


def print_case(case_name: str, records: list[dict]) -> None:
    ok = [r for r in records if "params" in r]
    used = min((r["n_segments"] for r in ok), default=0)
    print(f"\n=== {case_name}: {len(records)} seeds, {len(ok)} identified; methods "
          f"{sorted({r['method'] for r in ok})}; sub-records used (min) {used}")
    for r in records:
        if "error" in r:
            print(f"    seed {r['seed']}: {r['error'][:140]}")
    print("  parameter          truth        mean      bias/sd  centre bias/sd   seed sd   cov50  cov95  "
          "cov95(posterior)  width95/(2x1.96 sd)")
    for row in summarise(records):
        post = "      -" if np.isnan(row["cov95_posterior"]) else f"{100 * row['cov95_posterior']:6.0f} %"
        print(f"  {row['name'][:16]:<16} {row['truth']:>11.5g} {row['mean']:>11.5g} {row['bias'] / row['sd']:>+9.2f} "
              f"{row['centre_bias'] / row['sd']:>+9.2f}      {row['sd']:>9.3g}  {100 * row['cov50']:4.0f} % "
              f"{100 * row['cov95']:4.0f} %   {post}         "
              f"{row['width_ratio']:5.2f}")


def main(argv=None) -> int:
    from bayesnsi import EvidenceOptions

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--quick", action="store_true", help="6 seeds per case")
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--cases", nargs="+", default=list(CASE_NAMES), choices=CASE_NAMES)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--interval", default=None, choices=("auto", "noise", "surrogate", "segments", "posterior"))
    ap.add_argument("--n-replicates", type=int, default=None)
    ap.add_argument("--n-segments", type=int, default=None)
    ap.add_argument("--segment-fraction", type=float, default=None)
    ap.add_argument("--json", default=None, help="write the per-seed records here")
    ap.add_argument("--tables", default=None, help="print the tables of records written by --json, and stop")
    args = ap.parse_args(argv)
    if args.tables:
        with open(args.tables) as fh:
            kept = json.load(fh)
        for name in args.cases:
            print_case(name, sorted((r for r in kept if r["case"] == name), key=lambda r: r["seed"]))
        return 0
    n_seeds = 6 if args.quick else args.seeds
    given = {"n_segments": args.n_segments, "segment_fraction": args.segment_fraction, "interval": args.interval,
             "n_replicates": args.n_replicates}
    opts = EvidenceOptions().replace(**{k: v for k, v in given.items() if v is not None})
    records = run_seeds("bayesnsi interval calibration", one_seed, args.cases, n_seeds, args.seed0, opts,
                        args.workers, json_path=args.json)
    for name in args.cases:
        print_case(name, sorted((r for r in records if r["case"] == name), key=lambda r: r["seed"]))
    if args.json:
        print(f"\nrecords written to {args.json}")
    return 0


def run_seeds(title: str, task, cases, n_seeds: int, seed0: int, opts, workers: int, json_path=None) -> list[dict]:
    """Print the run's header, run ``task(case, seed, opts)`` for every case and seed in a process pool.

    With ``json_path`` the records are written as they come, so an interrupted study keeps its seeds.
    """
    print(title)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs, {workers} workers")
    print(f"cases {cases}; {n_seeds} seeds per case from {seed0}; evidence options {opts.to_dict()}")
    tasks = [(name, seed0 + j, opts) for name in cases for j in range(n_seeds)]
    records: list[dict] = []
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(task, *t) for t in tasks]
        for k, fut in enumerate(as_completed(futures), 1):
            records.append(fut.result())
            if json_path:
                with open(json_path, "w") as fh:
                    json.dump(records, fh, indent=1)
            print(f"  [{k}/{len(tasks)}] {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    print(f"wall time {time.perf_counter() - start:.0f} s")
    return records


if __name__ == "__main__":
    sys.exit(main())
