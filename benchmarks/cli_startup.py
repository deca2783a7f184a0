"""Start-up time of the command line: `bayesnsi --help`, `--version` and `simulate --help`.

Target: `bayesnsi --help` under 0.3 s. The parser imports no numerical library (numpy, scipy,
pandas, matplotlib load when a command runs; the top-level names of `bayesnsi` load on first
use), checked by tests/test_user_facing.py. Each command runs `--runs` times in a fresh process
(after one warm-up run that fills the OS file cache), like `hyperfine --warmup 1`; the table gives
mean ± sd, min and max wall time, and the bare interpreter's start-up for reference.

    .venv/bin/python benchmarks/cli_startup.py [--runs 20]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

BIN = Path(sys.executable).parent


def _time(argv: list[str], runs: int) -> list[float]:
    subprocess.run(argv, capture_output=True, check=True)  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args()
    commands = {
        "python -c pass (interpreter)": [sys.executable, "-c", "pass"],
        "bayesnsi --help": [str(BIN / "bayesnsi"), "--help"],
        "bayesnsi --version": [str(BIN / "bayesnsi"), "--version"],
        "bayesnsi simulate --help": [str(BIN / "bayesnsi"), "simulate", "--help"],
    }
    print(f"{'command':<32} {'mean [s]':>9} {'sd':>7} {'min':>7} {'max':>7}   ({args.runs} runs)")
    for name, argv in commands.items():
        t = _time(argv, args.runs)
        print(f"{name:<32} {statistics.mean(t):9.3f} {statistics.stdev(t):7.3f} {min(t):7.3f} {max(t):7.3f}")


if __name__ == "__main__":
    main()
