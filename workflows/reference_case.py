"""Run a reference case of the paper end to end: simulate it, then select among its candidates.

Usage::

    .venv/bin/python workflows/reference_case.py two-dof --out out/two-dof
    .venv/bin/python workflows/reference_case.py beam --out out/beam
    .venv/bin/python workflows/reference_case.py negative-stiffness --out out/twin

Writes ``OUT/data/<case>.csv`` with its config ``<case>.toml`` (SPEC 9), then
``OUT/results.json`` and ``OUT/report.html``. Only the public command line is used.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bayesnsi.cli import main
from bayesnsi.simulate import CASES


def run(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--command", choices=("select", "diagnose"), default="select")
    args = parser.parse_args(argv)
    out = Path(args.out)
    csv = out / "data" / f"{args.case}.csv"
    code = main(["simulate", args.case, "--seed", str(args.seed), "--out", str(csv), "--force"])
    if code:
        return code
    return main([args.command, str(csv.with_suffix(".toml")), "--out", str(out), "--force"])


if __name__ == "__main__":
    sys.exit(run())
