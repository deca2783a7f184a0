"""Benchmark of the selection pipeline (SPEC 6): wall time per stage, per candidate, per N.

1. Stage times per candidate, two-DOF case (seed 0, 1e3 samples, block_rows=60, order=4) and beam
   case (seed 0, 1e5 samples, 8 outputs, block_rows=60, order=32, band 1-30 Hz), 3 paper
   candidates each, replaying :func:`bayesnsi.select` (candidate_evidence per candidate, same
   seeds): identify, open-loop reconstruction, affine reconstruction (signatures; the innovations
   form by default), priors (:func:`bayesnsi.evidence.candidate_priors`: extended input +
   default_priors); then, for the "ar1" (default) and "white" likelihoods, the timings of
   ``EvidenceResult.settings``: statistics (time_statistics_s), emcee (time_sampling_s), estimators
   = bridge + Laplace + closed form (time_evidence_s), arviz summary (time_summary_s); "other" =
   marginal_evidence wall time minus those four. A stage that raises (wrong beam candidates:
   UnstableModelError) is timed up to the error ("other" for evidence) and reported as failed.
   n_walkers = max(32, 2 x parameters): emcee needs 2 per parameter and the beam's AR(1) posterior
   has q + 16 (the select default of 32 would refuse it).
2. Two-DOF model 1 at 1e4, 1e5, 1e6 samples: identify, affine reconstruction, then per likelihood
   statistics, emcee, estimators, summary, "evidence" = statistics + emcee + estimators (target
   < 5 s per candidate and likelihood, whatever N). Records: 1e4 = simulate_cases('two-dof', [0],
   duration=100); 1e5 and 1e6 from ONE batched simulate_cases('two-dof', range(10), duration=1000)
   (~10 s; 10,000 s simulated directly takes ~45 s): 1e5 = seed 0, 1e6 = the 10 concatenated.
3. ``bayesnsi demo --out TMP --quiet --force`` wall time in a subprocess (target < 30 s).

Threads: OMP/OPENBLAS/MKL threads are set to 1 before numpy is imported (and inherited by the demo
subprocess): this is a shared 2-core machine, where multithreaded BLAS was measured 3-18x slower
than one thread (SPEC 10). One-off imports (emcee, arviz) are paid by a warm-up call.

    .venv/bin/python benchmarks/selection.py           # everything (~1 min)
    .venv/bin/python benchmarks/selection.py --quick   # two-DOF only, N = 1e4 only, and the demo
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # must precede the numpy import (see the docstring)

import argparse  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import EvidenceOptions, NSIOptions, Signals, affine_reconstruction, identify  # noqa: E402
from bayesnsi.evidence import candidate_affine, candidate_priors, marginal_evidence  # noqa: E402
from bayesnsi.exceptions import BayesNSIError  # noqa: E402
from bayesnsi.simulate import simulate_case, simulate_cases  # noqa: E402

LIKELIHOODS = ("ar1", "white")
NSI = {"two-dof": dict(block_rows=60, order=4), "beam": dict(block_rows=60, order=32, band_hz=(1.0, 30.0))}
EVIDENCE = EvidenceOptions()  # the defaults of ``bayesnsi select``
KEYS = dict(stats="time_statistics_s", emcee="time_sampling_s", estim="time_evidence_s", summary="time_summary_s")
STAGES = ("identify", "recon", "affine", "priors", *KEYS, "other")
TARGET_EVIDENCE_S, TARGET_DEMO_S = 5.0, 30.0


def timed(times, key, fn, *args, **kwargs):
    """``fn(*args, **kwargs)``; its wall time goes to ``times[key]`` even when it raises."""
    t0 = time.perf_counter()
    try:
        return fn(*args, **kwargs)
    finally:
        times[key] = time.perf_counter() - t0


def priors_for(result, affine, signals, candidate):
    """The priors of ``bayesnsi.evidence.candidate_evidence`` (default evidence options)."""
    return candidate_priors(result, signals, affine, EVIDENCE, candidate)


def evidence(affine, priors, lik, seed, n_steps=None):
    """marginal_evidence as ``select`` runs it; returns the result and {stage: s} incl. "other"."""
    q, l = affine.signatures.shape[2], affine.measured.shape[1]
    n_walkers = max(EVIDENCE.n_walkers, 2 * (q + l * (1 + (lik == "ar1"))))
    t0 = time.perf_counter()
    ev = marginal_evidence(affine, priors, likelihood=lik, rng=np.random.default_rng(seed), warn=False,
                           n_walkers=n_walkers, n_steps=n_steps or EVIDENCE.n_steps,
                           n_burn=EVIDENCE.n_burn if n_steps is None else n_steps // 5)
    wall = time.perf_counter() - t0
    t = {k: float(ev.settings[v]) for k, v in KEYS.items()}
    t["other"] = wall - sum(t.values())
    return ev, t


def stage_table(name, case):
    """Section 1 for one case; one row per (candidate, likelihood), then the totals."""
    sig, opts = case.signals, NSI[name]
    print(f"\n== {name}: seed 0, N = {sig.n_samples}, {sig.displacement.shape[1]} outputs, {opts} ==")
    head = f"{'candidate':<10}{'lik':<6}" + "".join(f"{s:>8}" for s in (*STAGES, "total")) + "  log Z ± se (rhat, it)"
    print(head + "\n" + "-" * len(head))
    sums, per_cand, failures = dict.fromkeys(STAGES, 0.0), {}, []
    seeds = np.random.SeedSequence(EVIDENCE.seed).spawn(len(case.candidates))  # as select, seed 0
    for cand, seed in zip(case.candidates, seeds):
        t, rows = {}, []
        try:
            result = timed(t, "identify", identify, sig, cand, NSIOptions(**opts))
            timed(t, "recon", result.reconstruct, sig)
            affine = timed(t, "affine", candidate_affine, result, sig, EVIDENCE.residual)
            priors = timed(t, "priors", priors_for, result, affine, sig, cand)
        except BayesNSIError as err:
            rows.append(("-", {}, f"FAILED in {list(t)[-1]}: {type(err).__name__}"))
            failures.append(f"{cand.name}: {err}")
        for lik, child in zip(LIKELIHOODS, [] if rows else seed.spawn(len(LIKELIHOODS))):
            wall = {}
            try:
                ev, te = timed(wall, "other", evidence, affine, priors, lik, child)
                rows.append((lik, te, f"{ev.log_evidence:.2f} ± {ev.log_evidence_se:.3f} ({ev.rhat_max:.3f}, "
                                      f"{ev.bridge.n_iterations})"))
            except BayesNSIError as err:  # the wall time to the error is shown as "other"
                rows.append((lik, wall, f"evidence FAILED: {type(err).__name__}"))
                failures.append(f"{cand.name} {lik}: {err}")
        for i, (lik, row, note) in enumerate(rows):
            row = {**t, **row} if i == 0 else row  # NSI stages on the candidate's first row
            print(f"{cand.name:<10}{lik:<6}" + "".join(f"{row[s]:>8.3f}" if s in row else " " * 8 for s in STAGES)
                  + f"{sum(row.values()):>8.3f}  {note}", flush=True)
            for k, v in row.items():
                sums[k] += v
            per_cand[cand.name] = per_cand.get(cand.name, 0.0) + sum(row.values())
    sums["total"] = sum(sums.values())
    print("-" * len(head) + f"\n{'sum':<16}" + "".join(f"{v:>8.3f}" for v in sums.values()))
    print("per candidate [s]: " + ", ".join(f"{k} {v:.2f}" for k, v in per_cand.items()))
    for msg in failures:
        print("  " + msg)


def two_dof_records(quick):
    """{N: Signals} for section 2 (see the module docstring)."""
    out = {10_000: simulate_cases("two-dof", [0], duration=100.0)[0].signals}
    if quick:
        return out
    t0 = time.perf_counter()
    cases = simulate_cases("two-dof", range(10), duration=1000.0)
    print(f"(simulate_cases('two-dof', range(10), duration=1000): {time.perf_counter() - t0:.1f} s, one batch)")
    one = out[100_000] = cases[0].signals
    joined = {k: np.concatenate([getattr(c.signals, k) for c in cases]) for k in ("force", "displacement", "velocity")}
    out[1_000_000] = Signals(fs=one.fs, input_dofs=one.input_dofs, output_dofs=one.output_dofs, **joined)
    return out


def scaling_table(quick):
    """Section 2: two-DOF model 1 against N."""
    records = two_dof_records(quick)
    print(f"\n== two-DOF model 1 against N ({NSI['two-dof']}); evidence = stats + emcee + estim ==")
    head = f"{'N':>9} {'identify':>9}{'affine':>8} {'lik':<6}" + "".join(f"{k:>8}" for k in KEYS) + \
           f"{'evidence':>9}{'bridge it':>10}  target < {TARGET_EVIDENCE_S:g} s"
    print(head + "\n" + "-" * len(head))
    cand = simulate_case("two-dof", 0).candidates[0]
    seed = np.random.SeedSequence(0).spawn(3)[0]
    for n, sig in records.items():
        t = {}
        result = timed(t, "identify", identify, sig, cand, NSIOptions(**NSI["two-dof"]))
        affine = timed(t, "affine", candidate_affine, result, sig, EVIDENCE.residual)
        priors = priors_for(result, affine, sig, cand)
        for lik, child in zip(LIKELIHOODS, seed.spawn(len(LIKELIHOODS))):
            ev, te = evidence(affine, priors, lik, child)
            ev_s = te["stats"] + te["emcee"] + te["estim"]
            nsi = f"{t['identify']:>9.3f}{t['affine']:>8.3f}" if lik == LIKELIHOODS[0] else " " * 17
            print(f"{n:>9} {nsi} {lik:<6}" + "".join(f"{te[k]:>8.3f}" for k in KEYS) + f"{ev_s:>9.3f}"
                  f"{ev.bridge.n_iterations:>10}  " + ("met" if ev_s < TARGET_EVIDENCE_S else "MISSED"), flush=True)


def demo_time():
    """Section 3: the whole ``bayesnsi demo`` in a subprocess (threads inherited from os.environ)."""
    with tempfile.TemporaryDirectory() as tmp:  # .venv/bin/bayesnsi beside .venv/bin/python
        cmd = [str(Path(sys.executable).with_name("bayesnsi")), "demo", "--out", f"{tmp}/demo", "--quiet", "--force"]
        t0 = time.perf_counter()
        proc, dt = subprocess.run(cmd, capture_output=True, text=True), time.perf_counter() - t0
    print(f"\n== bayesnsi demo ==\n$ {' '.join(cmd)}")
    if proc.returncode:
        print(f"FAILED (exit {proc.returncode}) after {dt:.1f} s:\n{proc.stderr[-2000:]}")
    else:
        print(f"wall time {dt:.1f} s; target < {TARGET_DEMO_S:g} s: {'met' if dt < TARGET_DEMO_S else 'MISSED'}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="two-DOF only, N = 1e4 only, and the demo")
    args = parser.parse_args()
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.platform()}, {os.cpu_count()} cpus, "
          f"load average {load}; OMP/OPENBLAS/MKL threads = 1")
    print(f"evidence settings: {EVIDENCE.n_steps} steps, {EVIDENCE.n_burn} burn-in, "
          f">= {EVIDENCE.n_walkers} walkers; times in s")
    two = simulate_case("two-dof", 0)
    t0 = time.perf_counter()  # warm-up: imports and first-call costs are not charged to model 1
    res = identify(two.signals, two.candidates[0], NSIOptions(**NSI["two-dof"]))
    aff = affine_reconstruction(res, two.signals)
    evidence(aff, priors_for(res, aff, two.signals, two.candidates[0]), "ar1", 0, n_steps=100)
    print(f"warm-up (imports + a 100-step evidence): {time.perf_counter() - t0:.2f} s")
    stage_table("two-dof", two)
    if not args.quick:
        t0, beam = time.perf_counter(), simulate_case("beam", 0)
        print(f"\n(beam simulation: {time.perf_counter() - t0:.1f} s)", end="")
        stage_table("beam", beam)
    scaling_table(args.quick)
    demo_time()


if __name__ == "__main__":
    main()
