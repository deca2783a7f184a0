"""``bayesnsi demo --out DIR``: the paper's two-DOF case end to end (simulate, identify, select)."""

from __future__ import annotations

import time
from argparse import Namespace
from pathlib import Path

from ._common import progress

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "demo",
        help="run the paper's two-DOF case end to end and write a report",
        description="Simulate the paper's two-DOF case (docs/method.md §8), identify its three candidates by NSI, "
        "rank them and write DIR/report.html and DIR/results.json.",
        epilog="example: bayesnsi demo --out demo-report",
    )
    p.add_argument("--out", default="demo-report", help="output directory (default: demo-report)")
    p.add_argument("--seed", type=int, default=0, help="simulation seed (default 0)")
    p.add_argument("--force", action="store_true", help="overwrite an existing report")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..io import prepare_output_dir
    from ..io.results import output_folder
    from . import select, simulate

    start = time.perf_counter()
    resources = getattr(args, "resources", None)  # main()'s ExitStack: the folder stays locked until the end
    if resources is not None:
        out = resources.enter_context(output_folder(args.out, args.force))
    else:
        out = prepare_output_dir(args.out, force=args.force)
    csv = Path(out) / "data" / "two_dof.csv"
    simulate.run(
        Namespace(case="two-dof", seed=args.seed, noise=None, duration=None, out=str(csv), force=True, quiet=args.quiet)
    )
    select.run(
        Namespace(
            config=str(csv.with_suffix(".toml")), out=str(out), force=True, quiet=args.quiet, no_figures=False, jobs=1,
            scheduler=None, no_cache=False, resources=getattr(args, "resources", None),
        )
    )
    progress(f"demo finished in {time.perf_counter() - start:.1f} s; open {Path(out) / 'report.html'}", args.quiet)
    print(Path(out) / "report.html")
    return 0
