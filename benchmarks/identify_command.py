"""Cost of `bayesnsi identify` as a command against the identification it runs (issue 16).

The beam case (docs/method.md §8: 1e5 samples, 1 force, 8 displacements + 8 velocities: 16
response channels) with its true candidate {x13², x13³} and the case's recommended NSI settings:
`identify()` in-process on the loaded signals (best of 2), then the command in a fresh process
with `--no-figures` (start-up, CSV reading, identification, results.json) and with the report
(FRF magnitude and phase of the 8 pairs, λ(ω), singular values, stabilisation diagram,
measured-vs-model overlays). Target: the command at most 2x the identification. Also with plain
settings (the [nsi] defaults for B/D and C, no pole refinement), where the identification takes
0.17-0.18 s and Python start-up and imports dominate the command.

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


def _core(config: Path, repeats: int = 3) -> tuple[float, int, int]:
    """Best time of identify() in-process on the loaded signals; samples and response channels."""
    from bayesnsi.io import load_config, load_signals
    from bayesnsi.nsi import identify

    loaded = load_config(config)
    signals = load_signals(loaded)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        identify(signals, loaded.candidates[0], loaded.nsi)
        times.append(time.perf_counter() - start)
    return min(times), signals.n_samples, signals.displacement.shape[1]


def main() -> None:
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
            core, n_samples, n_channels = _core(path)
            bare = min(_command(["identify", str(path), "--out", str(folder / f"a{k}{label[0]}"), "--quiet",
                                 "--no-figures", "--no-cache"]) for k in range(3))
            rows += [(f"{label}: identify() in-process (best of 3)", core, core),
                     (f"{label}: command, --no-figures (best of 3)", bare, core)]
            if label == "case settings":
                full = _command(["identify", str(path), "--out", str(folder / "b"), "--quiet", "--no-cache"])
                rows.append((f"{label}: command with report.html", full, core))
    print(f"beam, {n_samples} samples, {n_channels} displacements + velocities, 1 force")
    print(f"{'what':<52} {'time [s]':>9} {'/ identify()':>13}")
    for name, value, core in rows:
        print(f"{name:<52} {value:9.2f} {value / core:13.2f}")


if __name__ == "__main__":
    main()
