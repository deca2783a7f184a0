"""Benchmark of bayesnsi.nsi.identify(): wall time and peak memory against record length.

Measures identify() on the beam case (SPEC 8.2: 8 displacement outputs, 1 force, 1000 Hz) with
its true candidate {x13**2, x13**3}, block_rows=40, order=32, default B/D (output-error), at 1e4,
1e5 and 1e6 samples, for the fast correlation route and the LQ reference route in the same run:
wall time (best of 3 below 1e6), and the case's recommended, errors-in-variables-aware settings
("accurate": prediction-error B, C, D and refined in-band poles; "B/D" then holds none of its
time, which is in "other"), the time of the main stages (Hankel Gram/factor, projection +
SVD, B/D; "other" = extended input, scaling, FRF/coefficients), the peak memory beyond the data,
the LQ/fast ratios; and the two-DOF case (1e3 samples, block_rows=60) as a small reference.

Targets (cost model: SPEC 3 "Cost", SPEC 10): fast route 1e5 samples < 1 s, 1e6 < 5 s, memory
not growing with N beyond the data (the LQ route holds the 2i·k x N Hankel matrix and copies).

Data: 1e5 = one 100 s beam record (seed 0), 1e4 = its first 10 s, 1e6 = seeds 0-9 simulated in one
batched call and concatenated (data content hardly matters for timing; the 9 seams are included).

Memory, in a fresh subprocess per (size, route) once the data are loaded: "traced" is the
tracemalloc peak during identify() (numpy reports its allocations to tracemalloc; tracing starts
after loading, so it is the peak minus the input arrays); LAPACK's internal work copies (e.g. in
QR) are malloc'ed and untraced, so "RSS" adds peak minus initial resident size (Linux VmHWM).

Threads: OMP/OPENBLAS/MKL threads are set to 1 before numpy is imported, because SPEC 10
measured multithreaded BLAS 3-18x slower than one thread on a loaded 2-core machine.

    .venv/bin/python benchmarks/nsi.py            # 1e4, 1e5, 1e6 (LQ skipped at 1e6)
    .venv/bin/python benchmarks/nsi.py --quick    # smoke run: 1e4 samples only
    .venv/bin/python benchmarks/nsi.py --full     # also the LQ route at 1e6 (> 14 GB)
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # must precede the numpy import (see the docstring)

import argparse  # noqa: E402
import importlib  # noqa: E402
import json  # noqa: E402
import pickle  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi import NSIOptions, Signals, identify, simulate_case  # noqa: E402
from bayesnsi.exceptions import UnstableModelError  # noqa: E402
from bayesnsi.simulate import simulate_cases  # noqa: E402

BLOCK_ROWS, ORDER, MB = 40, 32, 1e6
STAGES = [("factor", "_hankel", "gram_factor"), ("factor", "_hankel", "lq_factor"), ("svd", "_subspace", "oblique_svd"),
          ("bd", "_subspace", "input_matrices_robust"), ("bd", "identify", "refine_output_error")]
# (stage, module of bayesnsi.nsi, function): identify() looks these names up at call time
STAGE_NAMES = ("factor", "svd", "bd")
ACCURATE = dict(bd_method="prediction-error", c_method="prediction-error", refine_poles=(1.5, 85.0))
"""The beam case's recommended settings (errors in variables handled; measured in benchmarks/beam_bias.py)."""


def _proc_status(key, reset_peak=False):
    """A /proc/self/status entry (VmRSS, VmHWM) in bytes; None off Linux or if the reset fails."""
    try:
        if reset_peak:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")  # VmHWM := current RSS
        with open("/proc/self/status") as fh:
            return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key + ":"))
    except (OSError, StopIteration):
        return None


def _instrument(timings):
    """Wrap the stage functions, which identify() looks up at call time, to accumulate their time."""
    for stage, module_name, name in STAGES:
        module = importlib.import_module(f"bayesnsi.nsi.{module_name}")
        setattr(module, name, _timed(getattr(module, name), stage, timings))


def _timed(function, stage, timings):
    """``function`` wrapped to add its wall time to ``timings[stage]``."""

    def timed(*args, **kwargs):
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            timings[stage] += time.perf_counter() - start

    return timed


def worker(path, route):
    """Subprocess: time identify() on the pickled (signals, terms), then measure its memory."""
    with open(path, "rb") as fh:
        signals, terms = pickle.load(fh)  # terms as (expression, location) pairs
    warnings.simplefilter("ignore")  # spurious-pole warnings are not the point here
    options = dict(route=route) if route != "accurate" else dict(route="correlation", **ACCURATE)
    nsi = NSIOptions(block_rows=BLOCK_ROWS, order=ORDER, **options)
    run = lambda s: identify(s, terms, nsi)  # noqa: E731
    try:  # warm-up (lazy imports, first-call costs); so short a record may give an unstable model
        run(signals.segment(0, 5000))
    except UnstableModelError:
        pass
    timings = dict.fromkeys(STAGE_NAMES, 0.0)
    _instrument(timings)
    rss0 = _proc_status("VmRSS", reset_peak=True)
    best, stages = np.inf, {}
    for _ in range(3 if signals.n_samples <= 100_000 else 1):
        timings.update(dict.fromkeys(STAGE_NAMES, 0.0))
        start = time.perf_counter()
        run(signals)
        elapsed = time.perf_counter() - start
        if elapsed < best:
            best, stages = elapsed, dict(timings)
    rss = _proc_status("VmHWM") - rss0 if rss0 else None
    tracemalloc.start()  # after the data are loaded: the peak is the memory beyond the data
    run(signals)
    traced = tracemalloc.get_traced_memory()[1]
    print(json.dumps({"time": best, "stages": stages, "traced": traced, "rss": rss}))


def measure(path, route):
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", path, route],
                         capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"worker failed ({route}):\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def machine_summary():
    model = platform.processor()
    if os.path.exists("/proc/cpuinfo"):
        with open("/proc/cpuinfo") as fh:
            model = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), model)
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    try:
        from threadpoolctl import threadpool_info

        blas = "; ".join(f"{p['internal_api']} {p['version']}, {p['num_threads']} thread(s)" for p in threadpool_info())
    except ImportError:  # numpy >= 1.25 has the dict mode
        info = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
        blas = f"{info['name']} {info.get('openblas configuration', info.get('version', ''))} (numpy.show_config)"
    threads = ", ".join(f"{v}={os.environ[v]}" for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"))
    return (f"python {platform.python_version()}, numpy {np.__version__}, {platform.platform()}\n"
            f"cpu: {model}; {os.cpu_count()} logical cpus; load average {load}\nBLAS: {blas}\nthreads: {threads}")


def beam_records(quick):
    """Candidate {x13², x13³} and {n_samples: Signals}; see the module docstring."""
    if quick:
        case = simulate_case("beam", 0, duration=10.0)
        return case.candidates[2], {10_000: case.signals}
    cases = simulate_cases("beam", range(10))  # one batched time loop for the 10 seeds
    one = cases[0].signals
    joined = {k: np.concatenate([getattr(c.signals, k) for c in cases]) for k in ("force", "displacement", "velocity")}
    big = Signals(fs=one.fs, input_dofs=one.input_dofs, output_dofs=one.output_dofs, **joined)
    return cases[0].candidates[2], {10_000: one.segment(0, 10_000), 100_000: one, 1_000_000: big}


def two_dof_reference():
    case, out = simulate_case("two-dof", 0), []  # 10 s at 100 Hz = 1e3 samples
    for route in ("correlation", "lq"):
        stamps = [time.perf_counter()]
        for _ in range(5):
            identify(case.signals, case.candidates[0], NSIOptions(block_rows=60, order=4, route=route))
            stamps.append(time.perf_counter())
        out.append(f"{route} {np.diff(stamps).min() * 1e3:.0f} ms")
    return "two-DOF reference (1e3 samples, block_rows=60, order=4, best of 5): " + ", ".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: 1e4 samples only")
    parser.add_argument("--full", action="store_true", help="also run the LQ route at 1e6 samples")
    parser.add_argument("--worker", nargs=2, metavar=("PICKLE", "ROUTE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(*args.worker)
    print(machine_summary() + "\n" + two_dof_reference())
    candidate, records = beam_records(args.quick)
    print(f"\nbeam, candidate {{{', '.join(t.expr.canonical for t in candidate.terms)}}} at DOF 13, block_rows="
          f"{BLOCK_ROWS}, order={ORDER}, bd_method=output-error; times [s], memory beyond the input data [MB]")
    head = f"{'N':>9} {'route':<12}{'time':>7}{'factor':>8}{'proj+SVD':>9}{'B/D':>7}{'other':>7}{'data':>7}" + \
        f"{'traced':>8}{'RSS':>7}"
    print(head + "\n" + "-" * len(head))
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n, signals in records.items():
            data = sum(a.nbytes for a in (signals.force, signals.displacement, signals.velocity))
            path = os.path.join(tmp, f"beam_{n}.pkl")
            with open(path, "wb") as fh:
                pickle.dump((signals, [(t.expr.text, t.at) for t in candidate.terms]), fh, protocol=5)
            for route in ("correlation", "lq", "accurate"):
                if route == "accurate" and n >= 1_000_000 and not args.full:
                    print(f"{n:>9} {route:<12}skipped (run with --full)")
                    continue
                if route == "lq" and n >= 1_000_000 and not args.full:
                    k = 1 + len(candidate.terms) + 8  # channels of z = [f, -n_1, -n_2, y_1..y_8]
                    need = f"~{2 * BLOCK_ROWS * k * n * 8 * 2 / 1e9:.0f} GB = 2i·k·N·8 B x2"
                    if results.get((100_000, "lq"), {}).get("rss"):
                        need += f"; RSS at 1e5 x10: ~{results[100_000, 'lq']['rss'] * n / 1e5 / 1e9:.0f} GB"
                    print(f"{n:>9} {route:<12}skipped (needs {need}; run with --full)")
                    continue
                r = results[n, route] = measure(path, route)
                s, rss = r["stages"], "n/a" if r["rss"] is None else f"{r['rss'] / MB:.0f}"
                line = f"{n:>9} {route:<12}{r['time']:>7.3f}{s['factor']:>8.3f}{s['svd']:>9.3f}{s['bd']:>7.3f}" \
                       f"{r['time'] - sum(s.values()):>7.3f}{data / MB:>7.0f}{r['traced'] / MB:>8.0f}{rss:>7}"
                if route == "lq":  # LQ / fast ratios; the RSS one only when the fast RSS is above noise
                    fast = results[n, "correlation"]
                    line += f"   LQ/fast: time x{r['time'] / fast['time']:.1f}, "
                    line += f"traced x{r['traced'] / fast['traced']:.0f}"
                    line += f", RSS x{r['rss'] / fast['rss']:.0f}" if r["rss"] and (fast["rss"] or 0) > 10 * MB else ""
                print(line, flush=True)
    for n, target in ((100_000, 1.0), (1_000_000, 5.0)):
        if (n, "correlation") in results:
            t = results[n, "correlation"]["time"]
            print(f"target: fast route at N={n:.0e} < {target:g} s: {t:.2f} s, {'met' if t < target else 'MISSED'}")


if __name__ == "__main__":
    main()
