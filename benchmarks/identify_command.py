"""Cost of `bayesnsi identify` as a command against the identification it runs (issue 16).

The beam case (docs/method.md §8: 1e5 samples, 1 force, 8 displacements + 8 velocities: 16
response channels) with its true candidate {x13², x13³} and the case's recommended NSI settings:
`identify()` in-process on the loaded signals (best of 2), then the command in a fresh process
with `--no-figures` (start-up, CSV reading, identification, results.json) and with the report
(FRF magnitude and phase of the 8 pairs, λ(ω), singular values, stabilisation diagram,
measured-vs-model overlays). Target: the command at most 2x the identification.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/identify_command.py
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent / "bayesnsi"


def _command(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run([str(BIN), *args], check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    from bayesnsi.io import load_config, load_signals
    from bayesnsi.nsi import identify

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        _command(["simulate", "beam", "--seed", "0", "--out", str(folder / "beam.csv"), "--quiet"])
        text = (folder / "beam.toml").read_text()
        head = text[: text.index("[meta]")]
        config = folder / "one.toml"
        config.write_text(head + '[[candidates]]\nname = "model 3"\nterms = [{ expr = "x13**2", at = 13 }, '
                          '{ expr = "x13**3", at = 13 }]\n')
        loaded = load_config(config)
        signals = load_signals(loaded)
        times = []
        for _ in range(2):
            start = time.perf_counter()
            identify(signals, loaded.candidates[0], loaded.nsi)
            times.append(time.perf_counter() - start)
        core = min(times)
        bare = _command(["identify", str(config), "--out", str(folder / "a"), "--quiet", "--no-figures", "--no-cache"])
        full = _command(["identify", str(config), "--out", str(folder / "b"), "--quiet", "--no-cache"])
    print(f"beam, {signals.n_samples} samples, {signals.displacement.shape[1]} displacements + velocities, 1 force")
    print(f"{'what':<44} {'time [s]':>9} {'/ identify()':>13}")
    for name, value in (("identify() in-process (best of 2)", core), ("command, --no-figures", bare),
                        ("command with report.html", full)):
        print(f"{name:<44} {value:9.2f} {value / core:13.2f}")


if __name__ == "__main__":
    main()
