"""Cost of `bayesnsi identify` as a command against the identification it runs.

The beam case (docs/method.md §8: 1e5 samples, 1 force, 8 displacements + 8 velocities: 16
response channels) with its true candidate {x13², x13³}, under two settings:

* the case's recommended settings (prediction-error B/D and C, refined in-band poles), the ones
  `bayesnsi simulate beam` writes and the beam figures of docs/accuracy.md use;
* plain settings (the [nsi] defaults for B/D and C, no pole refinement), where the
  identification takes 0.16-0.18 s and Python start-up, imports and reading the CSV dominate.

For each: `identify()` in-process on the loaded signals, then the command in a fresh process with
`--no-figures` (start-up, CSV reading, identification, reconstruction for the NRMSE,
results.json) and with its default report (report.html: FRF magnitude and phase of the 8 pairs,
λ(ω), singular values, stabilisation diagram, measured-vs-model overlays). Each is the best of
`--repeats` runs, all in this one run; the ratio is command wall time / `identify()` wall time.
The CPU columns (this process's CPU time for `identify()`, the child's for a command) are less
disturbed by other jobs on a shared machine. Target: the command at most 2x the identification.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/identify_command.py [--repeats 3]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent / "bayesnsi"


def _command(args: list[str]) -> tuple[float, float]:
    """Wall and CPU time (user + system of the child) of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([str(BIN), *args], check=True, capture_output=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _best(runs: list[tuple[float, float]]) -> tuple[float, float]:
    return min(r[0] for r in runs), min(r[1] for r in runs)


def _core(config: Path, repeats: int) -> tuple[tuple[float, float], int, int]:
    """Best wall and CPU time of identify() in-process on the loaded signals; samples and response channels."""
    from bayesnsi.io import load_config, load_signals
    from bayesnsi.nsi import identify

    loaded = load_config(config)
    signals = load_signals(loaded)
    runs = []
    for _ in range(repeats):
        start, cpu = time.perf_counter(), time.process_time()
        identify(signals, loaded.candidates[0], loaded.nsi)
        runs.append((time.perf_counter() - start, time.process_time() - cpu))
    n_channels = signals.displacement.shape[1] + (0 if signals.velocity is None else signals.velocity.shape[1])
    return _best(runs), signals.n_samples, n_channels


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs of each (default 3)")
    repeats = parser.parse_args(argv).repeats
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        _command(["simulate", "beam", "--seed", "0", "--out", str(folder / "beam.csv"), "--quiet"])
        text = (folder / "beam.toml").read_text()
        head = text[: text.index("[meta]")]
        candidate = ('[[candidates]]\nname = "model 3"\n'
                     'terms = [{ expr = "x13**2", at = 13 }, { expr = "x13**3", at = 13 }]\n')
        config, plain = folder / "one.toml", folder / "plain.toml"
        config.write_text(head + candidate)
        # plain settings: the [nsi] defaults for B/D and C, no pole refinement
        kept = [line for line in head.splitlines(keepends=True)
                if not line.startswith(("bd_method", "refine_poles", "c_method"))]
        plain.write_text("".join(kept) + candidate)
        for label, path in (("case settings", config), ("plain settings", plain)):
            core, n_samples, n_channels = _core(path, repeats)
            out = str(folder / f"out-{label[0]}")
            common = ["identify", str(path), "--out", out, "--quiet", "--no-cache", "--force"]
            bare = _best([_command([*common, "--no-figures"]) for _ in range(repeats)])
            full = _best([_command(common) for _ in range(repeats)])
            rows += [(f"{label}: identify() in-process", core, core),
                     (f"{label}: command, --no-figures", bare, core),
                     (f"{label}: command with report.html (default)", full, core)]
    print(f"beam, {n_samples} samples, {n_channels} response channels (displacements + velocities), 1 force; "
          f"best of {repeats}")
    print(f"{'what':<50} {'wall [s]':>9} {'/ identify()':>13} {'CPU [s]':>9} {'/ identify()':>13}")
    for name, (wall, cpu), (core_wall, core_cpu) in rows:
        print(f"{name:<50} {wall:9.2f} {wall / core_wall:13.2f} {cpu:9.2f} {cpu / core_cpu:13.2f}")


if __name__ == "__main__":
    main()
