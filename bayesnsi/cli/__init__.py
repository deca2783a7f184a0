"""The ``bayesnsi`` command line: one small module per command, each with ``main(args) -> int``.

Exit codes (:data:`EXIT_CODES`): 0 success; 1 internal failure; 2 bad input (a
:class:`~bayesnsi.exceptions.BayesNSIError`: config, data, output folder, scheduler; or a path
longer than the system accepts); 74 an I/O fault of the system (:class:`OSError`: read-only or
full disk); 130 interrupted (SIGINT, Ctrl-C); 143 terminated (SIGTERM). Every error is reported
in one line on stderr, without a traceback unless ``--debug``. On SIGINT and SIGTERM the local
worker processes are stopped before exiting.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import signal
import sys
import traceback

from .._text import printable
from .._version import __version__
from ..exceptions import BayesNSIError
from ._warnings import plain_warnings

__all__ = ["EXIT_CODES", "main", "build_parser"]

EXIT_CODES = {
    0: "success",
    1: "internal error (a bug: rerun with --debug and report the traceback)",
    2: "bad input: config, data, options, output folder (exists or in use) or Dask scheduler",
    74: "I/O fault: the output could not be written (read-only file system, disk full, permissions)",
    130: "interrupted (SIGINT, Ctrl-C); finished candidates stay cached in DIR/.cache",
    143: "terminated (SIGTERM); finished candidates stay cached in DIR/.cache",
}
"""Exit codes of ``bayesnsi`` and their meaning (also listed by ``bayesnsi --help``)."""

_EPILOG = """examples:
  bayesnsi simulate two-dof --seed 1 --out data/two_dof.csv
  bayesnsi identify data/two_dof.toml --out results/two_dof
  bayesnsi select data/two_dof.toml --out results/two_dof_selection
  bayesnsi demo --out demo-report

exit codes:
""" + "".join(f"  {code:<4} {meaning}\n" for code, meaning in EXIT_CODES.items())


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that the same clean-up as for Ctrl-C runs."""


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
    parser.add_argument("--version", action="version", version=f"bayesnsi {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in (simulate, identify, select, diagnose, demo):
        module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit code (see :data:`EXIT_CODES`).

    A command's ``run(args)`` finds in ``args.resources`` a :class:`contextlib.ExitStack` that
    stays open until the command has ended (normally, by an error or by a signal): resources it
    enters there, such as the lock of the output folder
    (:func:`bayesnsi.io.results.output_folder`), are released before the exit code is returned.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if "matplotlib" in sys.modules:  # reports are written to files; no display is needed
        sys.modules["matplotlib"].use("Agg")
    else:  # not imported here: a command without figures (--no-figures) never imports it
        os.environ["MPLBACKEND"] = "Agg"
    with _sigterm_raises(), plain_warnings(), contextlib.ExitStack() as args.resources:
        try:
            return int(args.run(args) or 0)
        except KeyboardInterrupt as stop:
            return _stopped(args, isinstance(stop, _Terminated))
        except Exception as err:  # noqa: BLE001 - every failure becomes one line and an exit code
            return _report_error(args, err)


def _report_error(args, err: Exception) -> int:
    if args.debug:
        traceback.print_exc()
    if isinstance(err, BayesNSIError):
        text, code = f"error: {err}", 2
    elif isinstance(err, OSError) and err.errno == errno.ENAMETOOLONG:  # a path given is bad input
        name = str(err.filename)
        name = name if len(name) <= 80 else f"{name[:77]}..."
        text, code = f"error: {err.strerror}: {name!r} ({len(str(err.filename))} characters); choose a shorter path", 2
    elif isinstance(err, OSError):
        where = f" ({err.filename})" if err.filename and str(err.filename) not in str(err) else ""
        advice = "free space or fix permissions and rerun (finished candidates are cached)"
        text, code = f"I/O error: {err}{where}; {advice}", 74
    else:
        text, code = (
            f"internal error: {type(err).__name__}: {err} "
            "(rerun with --debug for the traceback and please report it)",
            1,
        )
    print(f"bayesnsi {args.command}: {printable(' '.join(text.split()), keep_newlines=False)}", file=sys.stderr)
    return code


def _stopped(args, terminated: bool) -> int:
    from .._dispatch import shutdown_workers

    with _signals_ignored():
        shutdown_workers()
    print(f"bayesnsi {args.command}: {'terminated (SIGTERM)' if terminated else 'interrupted'}", file=sys.stderr)
    return 143 if terminated else 130


@contextlib.contextmanager
def _sigterm_raises():
    """Turn SIGTERM into :class:`_Terminated` in the main thread while the command runs."""

    def handler(signum, frame):
        raise _Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def _signals_ignored():
    """Ignore a second SIGINT/SIGTERM while the workers are being stopped."""
    try:
        previous = {sig: signal.signal(sig, signal.SIG_IGN) for sig in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for sig, action in previous.items():
            signal.signal(sig, action)
