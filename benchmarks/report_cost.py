"""CPU cost of the HTML report of ``bayesnsi select``: with the report against ``--no-figures``.

The two-DOF case (``bayesnsi simulate two-dof --seed 1 --duration 100``) with its first two
candidates (model 1, model 2; the [meta] table left out). ``select`` runs alternately with the
report and with ``--no-figures`` (which skips the report entirely, docs/cli.md), ``--runs`` times
each, every run in a fresh process writing to a fresh folder (no cache), one BLAS thread. CPU time
is user + system of the child process (as ``/usr/bin/time -f "%U %S"`` gives it). Target: the run
with the report at most 1.3x the run without.

A last run with the report, in a process of its own, times the report's parts: building it (the
figures and tables; ``import matplotlib.pyplot`` and arviz-plots on first use included) and
rendering each figure to PNG (``figure_png``: layout, drawing, encoding), figure by figure.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/report_cost.py [--runs 3]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_ONE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _case(folder: Path) -> Path:
    """Simulate the two-DOF record and write a config with its first two candidates; returns the config."""
    subprocess.run([sys.executable, "-m", "bayesnsi", "simulate", "two-dof", "--seed", "1", "--duration", "100",
                    "--out", str(folder / "two_dof.csv"), "--quiet"], check=True, env=_env())
    text = (folder / "two_dof.toml").read_text()
    head, rest = text.split("[meta]", 1)
    candidates = rest.split("[[candidates]]")[1:3]
    config = folder / "two.toml"
    config.write_text(head + "".join("[[candidates]]" + c for c in candidates))
    return config


def _env() -> dict:
    return {**os.environ, **_ONE_THREAD}


def _cpu_of(argv: list[str]) -> float:
    """User + system CPU seconds of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, check=True, env=_env(), capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _parts(config: Path, out: Path) -> None:
    """Run ``select`` with the report in this process and print the cost of its parts (CPU s).

    The report's modules are imported inside the timed block, as the command line imports them.
    """
    from bayesnsi import report as report_package
    from bayesnsi.cli import main as cli_main

    whole: list[float] = []
    built: list[float] = []
    costs: list[tuple[str, float]] = []
    build = report_package.selection_report

    def timed_build(*args, **kwargs):
        start = time.process_time()
        made = build(*args, **kwargs)
        built.append(time.process_time() - start)
        return made

    @contextlib.contextmanager
    def timed_report():  # the block in which the command line builds and writes the report
        start = time.process_time()
        from bayesnsi.report import document
        from bayesnsi.report.sections import held_figures

        render = document.figure_png

        def timed_png(fig, *args, **kwargs):
            label = fig.get_label() or "(no caption)"
            begin = time.process_time()
            png = render(fig, *args, **kwargs)
            costs.append((label, time.process_time() - begin))
            return png

        document.figure_png = timed_png
        with held_figures():
            yield
        whole.append(time.process_time() - start)

    report_package.selection_report = timed_build
    report_package.held_figures = timed_report  # (found before the package's lazy names)
    start = time.process_time()
    cli_main(["select", str(config), "--out", str(out), "--quiet"])
    total = time.process_time() - start
    print(f"  whole run in one process      {total:6.2f}")
    print(f"  the report                    {sum(whole):6.2f}  (building and writing it, its imports included)")
    print(f"    building it                 {sum(built):6.2f}  (figures and tables)")
    print(f"    rendering its figures       {sum(c for _, c in costs):6.2f}  ({len(costs)} figures to PNG)")
    for label, cost in costs:
        print(f"      {cost:5.2f}  {label[:90]}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--parts", nargs=2, metavar=("CONFIG", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.parts:
        _parts(Path(args.parts[0]), Path(args.parts[1]))
        return 0
    import bayesnsi

    print(f"bayesnsi {bayesnsi.__version__} from {Path(bayesnsi.__file__).parent}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        config = _case(folder)
        select = [sys.executable, "-m", "bayesnsi", "select", str(config), "--quiet"]
        cpu: dict[str, list[float]] = {"with the report": [], "--no-figures": []}
        for run in range(args.runs):  # alternate: the shared host's speed drifts
            cpu["with the report"].append(_cpu_of([*select, "--out", str(folder / f"report{run}")]))
            cpu["--no-figures"].append(_cpu_of([*select, "--out", str(folder / f"plain{run}"), "--no-figures"]))
        print(f"select two.toml (two-DOF, seed 1, 100 s; model 1, model 2), CPU s (user + sys), {args.runs} runs each")
        print(f"{'':<18} {'runs':<26} {'median':>7}")
        for name, times in cpu.items():
            print(f"{name:<18} {', '.join(f'{t:.2f}' for t in times):<26} {statistics.median(times):7.2f}")
        ratios = [a / b for a, b in zip(cpu["with the report"], cpu["--no-figures"])]
        ratio = statistics.median(cpu["with the report"]) / statistics.median(cpu["--no-figures"])
        print(f"ratio of medians {ratio:.2f} (pairwise: {', '.join(f'{r:.2f}' for r in ratios)}; target <= 1.30)")
        print("parts of one run with the report (CPU s, one process):")
        sys.stdout.flush()
        subprocess.run([sys.executable, __file__, "--parts", str(config), str(folder / "parts")], check=True,
                       env=_env())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
