"""Benchmark of a large candidate sweep: candidates per minute, serial vs joblib vs Dask.

The two-DOF case (seed 1, 20 s record = 2000 samples, block_rows=60, order=4) against every
subset of up to ``--max-terms`` effects of the full effect dictionary (7 effect types at DOF 1,
DOF 2 and between them: 21 terms; 232 candidates with max 2 terms), identified by NSI and ranked
by NRMSE (the plain ranking; ``--evidence`` adds a short-MCMC evidence per candidate). The same
sweep runs, in one invocation, with

1. one local worker (serial, in this process),
2. two local workers (joblib loky processes),
3. a Dask LocalCluster of two single-threaded worker processes on 127.0.0.1 (or, with
   ``--scheduler ADDRESS``, an existing cluster),

and the table gives backend, workers, candidates, wall time and candidates per minute. Wall
times include starting the worker pool / cluster connection (not the LocalCluster start, which
is reported separately). The three runs must give identical numbers (checked and printed).

Threads: OMP/OPENBLAS/MKL threads are 1 (shared 2-core machine; SPEC 10).

    .venv/bin/python benchmarks/sweep.py                 # 232 candidates (~1-2 min)
    .venv/bin/python benchmarks/sweep.py --max-terms 1   # 22 candidates (quick check)
    .venv/bin/python benchmarks/sweep.py --evidence      # + evidence (n_steps 300; slower)
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # must precede the numpy import (see the docstring)

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

from bayesnsi import EvidenceOptions, ExecutionOptions, NSIOptions, __version__, simulate_case  # noqa: E402
from bayesnsi.run import dictionary_candidates, run_candidates  # noqa: E402

NSI_SETTINGS = dict(block_rows=60, order=4)
NSI = NSIOptions(**NSI_SETTINGS)
EVIDENCE = EvidenceOptions(likelihood="ar1", compare=(), n_walkers=32, n_steps=300, n_burn=100, seed=1)


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-terms", type=int, default=2, help="largest number of terms per candidate (default 2)")
    parser.add_argument("--duration", type=float, default=20.0, help="record length [s] (default 20)")
    parser.add_argument("--evidence", action="store_true", help="also compute each candidate's evidence (short MCMC)")
    parser.add_argument("--workers", type=int, default=2, help="local / Dask workers of runs 2 and 3 (default 2)")
    parser.add_argument("--scheduler", default=None, help="use this Dask scheduler instead of a LocalCluster")
    return parser.parse_args()


def digest(outcomes):
    """The numbers that must not depend on the backend."""
    return [
        (o.name, o.status, o.nrmse, () if o.result is None else tuple(o.result.coefficient_values),
         None if o.evidences is None else tuple(e.log_evidence for e in o.evidences.values()))
        for o in outcomes
    ]


def timed_run(label, workers, signals, candidates, evidence, **backend):
    """One sweep on the backend ``ExecutionOptions(**backend)``: wall time, rate and outcomes."""
    start = time.perf_counter()
    outcomes = run_candidates(signals, candidates, NSI, evidence, execution=ExecutionOptions(**backend))
    wall = time.perf_counter() - start
    return {"backend": label, "workers": workers, "candidates": len(candidates), "wall_s": wall,
            "per_min": 60.0 * len(candidates) / wall, "outcomes": outcomes}


def main():
    args = parse_args()
    warnings.simplefilter("ignore")  # per-candidate warnings are kept in the records
    signals = simulate_case("two-dof", seed=1, duration=args.duration).signals
    candidates = dictionary_candidates([1, 2], max_terms=args.max_terms)
    evidence = EVIDENCE if args.evidence else None
    print(f"bayesnsi {__version__}, Python {platform.python_version()}, {os.cpu_count()} CPUs; two-DOF, "
          f"{signals.n_samples} samples, {len(candidates)} candidates, NSI {NSI_SETTINGS}, evidence: {bool(evidence)}")
    rows = [timed_run("serial", 1, signals, candidates, evidence)]
    rows.append(timed_run("joblib-loky", args.workers, signals, candidates, evidence, jobs=args.workers))
    if args.scheduler:
        rows.append(timed_run("dask", "cluster", signals, candidates, evidence, scheduler=args.scheduler))
    else:
        from dask.distributed import LocalCluster

        start = time.perf_counter()
        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:
            started = time.perf_counter() - start
            rows.append(timed_run("dask-localcluster", args.workers, signals, candidates, evidence,
                                  scheduler=cluster.scheduler_address))
        print(f"(Dask LocalCluster start: {started:.1f} s, not included)")
    print(f"\n{'backend':<20}{'workers':>8}{'candidates':>12}{'wall s':>10}{'candidates/min':>16}")
    for row in rows:
        print(f"{row['backend']:<20}{row['workers']!s:>8}{row['candidates']:>12}{row['wall_s']:>10.1f}{row['per_min']:>16.0f}")
    reference = digest(rows[0]["outcomes"])
    identical = all(digest(row["outcomes"]) == reference for row in rows[1:])
    print(f"\nidentical numbers across backends: {'yes' if identical else 'NO'}")
    ranked = sorted((o for o in rows[0]["outcomes"] if o.status == "ok"), key=lambda o: o.nrmse)
    failed = sum(o.status != "ok" for o in rows[0]["outcomes"])
    print(f"failed candidates (recorded with their reason): {failed}")
    print("best five by NRMSE (plain ranking):")
    for outcome in ranked[:5]:
        print(f"  {outcome.nrmse:.5f}  {outcome.name}")
    return 0 if identical else 1


if __name__ == "__main__":
    raise SystemExit(main())
