"""Calibration study of the model rankings (SPEC 6) on simulated reference cases.

What it measures
----------------
For each case (``two-dof``: SPEC 8.1 / paper III.A, 3 candidates, true "model 1" = v1|v1|;
``three-dof``: a 3-DOF chain with a cubic spring between DOFs 1 and 2, 4 candidates, true
"model 1" = (x1-x2)³ at [1, 2], "model 4" its superset with x1³ at 1) it simulates many
seeded datasets, the output noise cycling over 1, 2, 5, 10 % (dataset ``j`` has seed
``seed0 + j`` and noise ``NOISE[j % 4]``), and on each dataset

1. identifies every candidate with :func:`bayesnsi.nsi.identify` and the case's recommended
   settings (``case.recommended``); a candidate whose identification or evidence fails gets
   probability 0;
2. computes the evidence of each identified candidate exactly as ``bayesnsi select`` does
   (:func:`bayesnsi.evidence.candidate_evidence`: affine reconstruction -> default priors ->
   emcee + bridge sampling) with ``EvidenceOptions()`` defaults, under the white-noise and the
   exact AR(1) likelihood, with a ``numpy.random.SeedSequence`` per candidate;
3. turns them into three probability vectors over the candidates (uniform model priors, via
   :func:`bayesnsi.evidence.compare_evidence`): the paper's plain ranking (Eq. 4, Gaussian
   likelihood at the ML noise level), the white-noise evidence posterior and the AR(1)
   evidence posterior.

It then reports, per case and per ranking:

* accuracy: how often the most probable candidate is the true one (also per noise level);
* the multi-class Brier score, mean over datasets of ``Σ_k (p_k - 1[k = true])²`` (0 is
  perfect, 2 is confidently wrong, ``1 - 1/S`` is the uniform guess);
* which candidate came out on top, how often;
* a reliability table: every probability assigned to every candidate in every dataset is put
  in a bin [0, 0.1), [0.1, 0.5), [0.5, 0.9), [0.9, 0.99), [0.99, 1]; per bin the count, the
  mean predicted probability and the observed frequency with which that candidate is the
  true model. A calibrated ranking has mean p ≈ observed frequency in every bin; an
  over-confident one puts wrong candidates in the top bin (observed frequency << mean p);

plus, as context, the relative error of the true model's NSI coefficient, the number of
convergence warnings and the bridge-vs-exact disagreement of the white-noise evidence.

Note that "the true model" is the simulated model, while what the evidence measures is how
well each candidate explains the data *given its NSI reconstruction*: the NSI estimate of the
underlying linear model is not exact, so the residual is not white noise and a superset can
absorb part of the NSI error. Miscalibration can therefore come from the likelihood (white vs
AR(1)) and from the identification step; this study measures the end-to-end behaviour.

Run::

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/calibration.py            # 60 datasets per case
    .venv/bin/python benchmarks/calibration.py --quick                      # 8 per case (smoke run)
    .venv/bin/python benchmarks/calibration.py --seeds 60 --n-steps 800 --json out.json

The thread variables (OMP/OPENBLAS/MKL/NUMEXPR = 1) are set before numpy is imported, and the
datasets run in a ``concurrent.futures.ProcessPoolExecutor`` with 2 workers by default.
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

NOISE_LEVELS = (1.0, 2.0, 5.0, 10.0)
CASE_NAMES = ("two-dof", "three-dof")
RANKINGS = ("plain", "white", "ar1")
BINS = (0.0, 0.1, 0.5, 0.9, 0.99, 1.0)
BIN_LABELS = ("[0, 0.1)", "[0.1, 0.5)", "[0.5, 0.9)", "[0.9, 0.99)", "[0.99, 1]")


def _git_state() -> str:
    import subprocess

    here = os.path.dirname(os.path.abspath(__file__))
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True, text=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                               capture_output=True, text=True)
        return head.stdout.strip() + (" + uncommitted changes" if dirty.stdout.strip() else "")
    except OSError:
        return "unknown"


def one_dataset(case_name: str, index: int, seed: int, noise: float, opts, seed0: int) -> dict:
    """Simulate, identify, compute evidences (``opts``: EvidenceOptions) and the three rankings for one dataset."""
    from bayesnsi import identify, simulate_case
    from bayesnsi.evidence import candidate_evidence, compare_evidence
    from bayesnsi.exceptions import BayesNSIError, ConvergenceWarning

    t0 = time.perf_counter()
    case = simulate_case(case_name, seed=seed, noise_percent=noise)
    names = [c.name for c in case.candidates]
    true_index = names.index(case.true_model)
    case_id = CASE_NAMES.index(case_name) if case_name in CASE_NAMES else len(CASE_NAMES)
    root = np.random.SeedSequence([seed0, case_id, index])
    cand_seeds, rank_seed = root.spawn(2)
    cand_seeds = cand_seeds.spawn(len(names))
    evidences, status, errors = {}, {}, {}
    n_warn, true_coef_error, exact_gap = 0, None, 0.0
    for cand, ss in zip(case.candidates, cand_seeds):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                result = identify(case.signals, cand, case.recommended)
            except (BayesNSIError, np.linalg.LinAlgError) as err:
                status[cand.name], errors[cand.name] = "nsi-failed", f"{type(err).__name__}: {err}"
                continue
            if cand.name == case.true_model:
                rel = result.coefficient_values / np.asarray(case.true_coefficients) - 1.0
                true_coef_error = [float(r) for r in rel]
            try:
                ev = candidate_evidence(result, case.signals, opts, ss, cand)
            except (BayesNSIError, np.linalg.LinAlgError) as err:
                status[cand.name], errors[cand.name] = "evidence-failed", f"{type(err).__name__}: {err}"
                continue
        n_warn += sum(issubclass(w.category, ConvergenceWarning) for w in caught)
        evidences[cand.name] = list(ev.values())
        status[cand.name] = "ok"
        white = ev.get("white")
        if white is not None and white.closed_form_log_evidence is not None:
            exact_gap = max(exact_gap, abs(white.log_evidence - white.closed_form_log_evidence))
    table = compare_evidence(
        {n: evidences.get(n) for n in names}, rng=np.random.default_rng(rank_seed)
    )
    probs = {}
    for rank in RANKINGS:
        column = f"p_{rank}"
        p = table[column].to_numpy(dtype=float) if column in table else np.zeros(len(names))
        probs[rank] = np.nan_to_num(p, nan=0.0).tolist()  # all failed: every candidate gets 0
    return {
        "case": case_name,
        "index": index,
        "seed": seed,
        "noise_percent": noise,
        "names": names,
        "true_index": true_index,
        "probabilities": probs,
        "status": status,
        "errors": errors,
        "convergence_warnings": n_warn,
        "true_coefficient_rel_error": true_coef_error,
        "white_bridge_vs_exact_nat": exact_gap,
        "seconds": time.perf_counter() - t0,
    }


# --------------------------------------------------------------------------------------
# scoring


def scores(records: list[dict], rank: str) -> dict:
    """Accuracy, Brier score, top-model counts and reliability bins of one ranking."""
    names = records[0]["names"]
    p = np.array([r["probabilities"][rank] for r in records])  # (D, S)
    truth = np.zeros_like(p)
    truth[np.arange(len(records)), [r["true_index"] for r in records]] = 1.0
    top = np.where(p.max(axis=1) > 0, p.argmax(axis=1), -1)  # -1: every candidate failed
    correct = top == np.array([r["true_index"] for r in records])
    brier = np.sum((p - truth) ** 2, axis=1)
    flat_p, flat_t = p.ravel(), truth.ravel()
    which = np.clip(np.digitize(flat_p, BINS[1:-1], right=False), 0, len(BIN_LABELS) - 1)
    bins = []
    for b in range(len(BIN_LABELS)):
        sel = which == b
        n = int(sel.sum())
        bins.append(
            {
                "bin": BIN_LABELS[b],
                "count": n,
                "mean_p": float(flat_p[sel].mean()) if n else float("nan"),
                "freq_true": float(flat_t[sel].mean()) if n else float("nan"),
                "n_true": int(flat_t[sel].sum()),
            }
        )
    return {
        "n": len(records),
        "accuracy": float(correct.mean()),
        "n_correct": int(correct.sum()),
        "brier": float(brier.mean()),
        "top_counts": {name: int(np.sum(top == k)) for k, name in enumerate(names)},
        "none_top": int(np.sum(top == -1)),
        "reliability": bins,
        "p_true_median": float(np.median(p[truth == 1])),
        "n_p_true_above_095": int(np.sum(p[truth == 1] > 0.95)),
    }


def _nsi_settings(options) -> dict:
    """Block rows, order and the other NSIOptions fields that differ from their defaults."""
    default = type(options)()
    values = {name: getattr(options, name) for name in options.names()}
    shown = ("block_rows", "order")
    return {name: value for name, value in values.items() if name in shown or value != getattr(default, name)}


def print_case(case_name: str, records: list[dict]) -> None:
    from bayesnsi import simulate_case

    case = simulate_case(case_name, seed=0, duration=1.0)
    names = records[0]["names"]
    print(f"\n=== {case_name}: true model {case.true_model!r}; {len(records)} datasets; "
          f"NSI settings {_nsi_settings(case.recommended)}")
    for cand in case.candidates:
        print(f"    {cand.name}: " + ", ".join(t.name for t in cand.terms))
    status = {}
    for r in records:
        for s in r["status"].values():
            status.setdefault(s, 0)
            status[s] += 1
    print("  candidate fits: " + ", ".join(f"{s} {n}" for s, n in sorted(status.items())))
    for r in records:
        for name, err in r["errors"].items():
            print(f"    seed {r['seed']} noise {r['noise_percent']:g} %: {name}: {err[:140]}")
    levels = sorted({r["noise_percent"] for r in records})
    by_noise = {lvl: [r for r in records if r["noise_percent"] == lvl] for lvl in levels}
    print("  true-model NSI coefficient, relative error [%] (median / 10th-90th percentile):")
    for lvl, recs in by_noise.items():
        e = np.array([r["true_coefficient_rel_error"][0] for r in recs if r["true_coefficient_rel_error"]]) * 100
        if e.size:
            low, high = np.percentile(e, 10), np.percentile(e, 90)
            print(f"    noise {lvl:>4g} %: {np.median(e):+6.1f}  ({low:+6.1f} .. {high:+6.1f})")
    warn = sum(r["convergence_warnings"] for r in records)
    gap = max(r["white_bridge_vs_exact_nat"] for r in records)
    print(f"  evidence convergence warnings: {warn} over {len(records) * len(names) * 2} evidence runs; "
          f"max |bridge - exact| (white) = {gap:.3f} nat")

    summary = {rank: scores(records, rank) for rank in RANKINGS}
    uniform = 1.0 - 1.0 / len(names)
    print(f"\n  ranking  top=true        Brier   median P(true)  P(true)>0.95  top model counts ({' / '.join(names)})")
    for rank, s in summary.items():
        counts = " / ".join(str(s["top_counts"][n]) for n in names)
        extra = f" (+{s['none_top']} all failed)" if s["none_top"] else ""
        print(f"  {rank:<7}  {s['n_correct']:>3}/{s['n']:<3} {100 * s['accuracy']:5.1f} %  {s['brier']:6.3f}"
              f"   {s['p_true_median']:12.3g}  {s['n_p_true_above_095']:>5}/{s['n']:<5}  {counts}{extra}")
    print(f"  (Brier of the uniform guess: {uniform:.3f})")

    print("\n  per noise level: accuracy (Brier)")
    print("  noise %    n  " + "".join(f"{rank:>18}" for rank in RANKINGS))
    for lvl, recs in by_noise.items():
        if not recs:
            continue
        cells = []
        for rank in RANKINGS:
            s = scores(recs, rank)
            cells.append(f"{100 * s['accuracy']:7.1f} % ({s['brier']:5.3f})")
        print(f"  {lvl:>6g} {len(recs):>4}  " + "".join(f"{c:>18}" for c in cells))

    for rank, s in summary.items():
        print_reliability(f"reliability, {rank}", s["reliability"])


def print_reliability(title: str, bins: list[dict]) -> None:
    print(f"\n  {title}")
    print("    bin            count   mean p   freq true  (n true)")
    for b in bins:
        if b["count"]:
            print(f"    {b['bin']:<13} {b['count']:>6}   {b['mean_p']:6.3f}   {b['freq_true']:8.3f}   ({b['n_true']})")
        else:
            print(f"    {b['bin']:<13} {0:>6}        -          -")


# --------------------------------------------------------------------------------------


def main(argv=None) -> int:
    from bayesnsi import EvidenceOptions

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=60, help="datasets per case (default 60: 15 per noise level)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 8 datasets per case")
    ap.add_argument("--seed0", type=int, default=1000, help="first simulation seed (default 1000)")
    ap.add_argument("--cases", nargs="+", default=list(CASE_NAMES), choices=CASE_NAMES)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--n-steps", type=int, default=None, help="emcee steps (default: EvidenceOptions)")
    ap.add_argument("--n-burn", type=int, default=None, help="emcee burn-in (default: EvidenceOptions)")
    ap.add_argument("--noise", type=float, nargs="+", default=list(NOISE_LEVELS),
                    help="noise levels [%%] cycled over the datasets (default 1 2 5 10; "
                         "true-model posterior > 0.95 on 19 of 20 two-DOF seeds: --cases two-dof --seeds 20 --noise 2)")
    ap.add_argument("--residual", default=None, choices=("innovations", "reconstruction"),
                    help="residual the evidence scores (default: EvidenceOptions)")
    ap.add_argument("--json", default=None, help="write the per-dataset records and scores here")
    args = ap.parse_args(argv)
    n_seeds = 8 if args.quick else args.seeds

    given = {"n_steps": args.n_steps, "n_burn": args.n_burn, "residual": args.residual}
    opts = EvidenceOptions(likelihood="ar1", compare=("white",)).replace(
        **{name: value for name, value in given.items() if value is not None}
    )

    print("bayesnsi calibration study (SPEC 6)")
    print(f"python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs, "
          f"{args.workers} workers, threads per worker 1; repository {_git_state()}")
    print(f"cases {args.cases}; {n_seeds} datasets per case, seeds {args.seed0}..{args.seed0 + n_seeds - 1}, "
          f"noise cycling over {', '.join(f'{n:g}' for n in args.noise)} %")
    print(f"evidence options: {opts.to_dict()}")

    tasks = [
        (name, j, args.seed0 + j, args.noise[j % len(args.noise)], opts, args.seed0)
        for name in args.cases
        for j in range(n_seeds)
    ]
    records: list[dict] = []
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        futures = [pool.submit(one_dataset, *t) for t in tasks]
        for k, fut in enumerate(as_completed(futures), 1):
            rec = fut.result()
            records.append(rec)
            if k % 10 == 0 or k == len(tasks):
                print(f"  [{k}/{len(tasks)}] {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    wall = time.perf_counter() - start
    cpu = sum(r["seconds"] for r in records)
    print(f"wall time {wall:.0f} s ({cpu / len(records):.1f} s per dataset in a worker)")

    out = {"options": opts.to_dict(), "n_seeds": n_seeds, "seed0": args.seed0, "records": records, "scores": {}}
    for name in args.cases:
        recs = sorted((r for r in records if r["case"] == name), key=lambda r: r["index"])
        print_case(name, recs)
        out["scores"][name] = {rank: scores(recs, rank) for rank in RANKINGS}
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"\nrecords written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
