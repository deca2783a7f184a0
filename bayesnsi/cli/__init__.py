"""The ``bayesnsi`` command line: one small module per command, each with ``main(args) -> int``.

Exit codes: 0 success, 2 bad input (a :class:`~bayesnsi.exceptions.BayesNSIError`, reported in
one line without a traceback unless ``--debug``), 1 internal failure.
"""

from __future__ import annotations

import argparse
import sys
import traceback

from ..exceptions import BayesNSIError

__all__ = ["main", "build_parser"]

_EPILOG = """examples:
  bayesnsi simulate two-dof --seed 1 --out data/two_dof.csv
  bayesnsi identify data/two_dof.toml --out results/two_dof
  bayesnsi select data/two_dof.toml --out results/two_dof_selection
  bayesnsi demo --out demo-report
"""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    from . import demo, diagnose, identify, select, simulate

    parser = argparse.ArgumentParser(
        prog="bayesnsi",
        description="Nonlinear subspace identification with Bayesian model selection.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (simulate, identify, select, diagnose, demo):
        module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit code."""
    import matplotlib

    matplotlib.use("Agg")  # reports are written to files; no display is needed
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except BayesNSIError as err:
        if args.debug:
            traceback.print_exc()
        print(f"bayesnsi {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"bayesnsi {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # noqa: BLE001 - last-resort report of an internal failure
        if args.debug:
            traceback.print_exc()
        print(
            f"bayesnsi {args.command}: internal error: {type(err).__name__}: {err} "
            "(rerun with --debug for the traceback and please report it)",
            file=sys.stderr,
        )
        return 1
