"""Property-based fuzzing of the command line and of the option tables ``[evidence]`` and ``[diagnose]``.

Tables: the real option names (``EvidenceOptions.names()``, ``LoopOptions.names()``) and unknown
keys, with values of every TOML type, near the limits of each option or anywhere; both
``from_mapping`` and :func:`~bayesnsi.io.load_config` give options or a ConfigError.

Command line: ``bayesnsi.cli.main(argv)`` on argument lists that mix the real subcommands and
flags (read from :func:`bayesnsi.cli.build_parser`) with random words, numbers (huge, negative,
nan) and paths (missing, a directory, /dev/null, a CSV that is not a config, a config whose data
file is missing, a valid config). It returns (or argparse exits with) 0 or 2 - never 1 (internal
error) or 74 - and prints no traceback unless ``--debug`` was given. No example computes for
long: identification and selection are replaced by a stub that raises a BayesNSIError once the
arguments, the config and the data have been checked, and simulations are capped at 1 s of record.

60 examples per test by default, 10 000 under ``BAYESNSI_HYPOTHESIS_PROFILE=long``; a deadline
of 2 s per example (5 s for the command line).
"""

import argparse
import contextlib
import dataclasses
import io
import math
import shutil
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import bayesnsi.simulate
from bayesnsi import cli
from bayesnsi.exceptions import BayesNSIError, BayesNSIWarning, ConfigError
from bayesnsi.io import dump_config, load_config
from bayesnsi.options import EvidenceOptions, LoopOptions
from tests._helpers.fuzz import CACHE_EXAMPLES, FOLDER
from tests._helpers.fuzz import SANE as _SANE
from tests._helpers.fuzz import outcome as _outcome
from tests._helpers.fuzz import patched as _patched
from tests._helpers.fuzz import scalars as _scalars

# ---------------------------------------------------------------------------------------------
# [evidence] and [diagnose] tables

_options_settings = settings(max_examples=CACHE_EXAMPLES, deadline=2000)

_option_scalars = (
    _scalars | st.integers() | st.integers(4300, 4310).map(lambda digits: 10**digits)  # too long to print
    | st.sampled_from([2**63, -(2**63) - 1, 10**400, -(10**400), 0, 1, 2, 3, 4, 300, 1501])
    | st.sampled_from([1e308, -1e308, 1.7976931348623157e308, 5e-324, 0.0, -0.0, 0.5, 1.4, 4.6, math.nan, -math.inf])
    | st.sampled_from(["ar999", "ar0", "ar50", "ar1", "white", "innovations", "reconstruction", "x^3", "sign(v)",
                       "clearance", "none", "", "\x00", "\x1b[2J", "\u202e", "a\nb"])
    | st.text(st.characters(codec="utf-8"), max_size=6)
)
_option_values = st.recursive(_option_scalars, lambda inner: st.lists(inner, max_size=4)
                              | st.dictionaries(st.text(max_size=4), inner, max_size=3), max_leaves=6)


def _near_limits(item):
    """Values of one option: its default, its choices, its bounds and one step either side, or any."""
    meta = item.metadata
    bounds = [b + step for b in (meta["low"], meta["high"]) if b is not None for step in (-1, -1e-9, 0, 1e-9, 1)]
    near = [item.default, *meta["choices"], *bounds, "ar2", ["white", "ar3"], ["x^3", "sign(v)"], []]
    near = st.sampled_from([value for value in near if value is not None])  # TOML has no None
    valid = st.sampled_from([value for value in (item.default, *meta["choices"]) if value is not None] or [[]])
    return st.one_of(valid, valid, near, near, _option_values)  # each table is mostly valid


def _option_table(options_class):
    """Tables of ``options_class``'s real keys (mostly) and a few unknown ones."""
    near = {item.name: _near_limits(item) for item in dataclasses.fields(options_class)}
    keys = st.sampled_from(options_class.names()) | st.sampled_from(["Seed", "n walkers", "", "unknown", "\x00"])
    return st.fixed_dictionaries({}, optional=near) | st.dictionaries(keys, _option_values, max_size=4)


def _fuzz_options_table(options_class, table):
    """``options_class.from_mapping`` and ``load_config`` with the table as its section."""
    options = _outcome(lambda: options_class.from_mapping(table))
    if not isinstance(options, BayesNSIError):
        assert options == options_class.from_mapping(options.to_dict())  # what it accepts, it accepts again
    try:
        text = dump_config(_patched({options_class.SECTION: table}))
    except BayesNSIError:
        return  # not writable as TOML (e.g. an integer beyond 64 bits); from_mapping saw it
    path = FOLDER / f"{options_class.SECTION}.toml"
    path.write_text(text, encoding="utf-8")
    config = _outcome(lambda: load_config(path))
    if not isinstance(config, BayesNSIError):
        loaded = config.evidence if options_class.SECTION == "evidence" else config.loop
        assert isinstance(loaded, options_class)


@_options_settings
@given(_option_table(EvidenceOptions))
def test_evidence_table_gives_options_or_config_error(table):
    _fuzz_options_table(EvidenceOptions, table)


@_options_settings
@given(_option_table(LoopOptions))
def test_diagnose_table_gives_options_or_config_error(table):
    _fuzz_options_table(LoopOptions, table)


# ---------------------------------------------------------------------------------------------
# the command line

MAX_SECONDS = 1.0  # longest simulated record


class _Reached(BayesNSIError):
    """Raised by the stubs where a real run would start computing."""


def _stub(*args, **kwargs):
    raise _Reached("arguments, config and data accepted; the computation is stubbed out by the fuzzer")


def _capped(function):
    """``function`` (a case simulator) with the record length capped at :data:`MAX_SECONDS`."""

    def capped(*args, duration=MAX_SECONDS, **kwargs):
        if isinstance(duration, float) and math.isfinite(duration):
            duration = min(duration, MAX_SECONDS)  # non-finite values go through: they must be refused
        return function(*args, duration=duration, **kwargs)

    return capped


@contextlib.contextmanager
def _cheap_commands():
    """Stub the computations behind the commands (identify, select, diagnose, demo) for a block."""
    with pytest.MonkeyPatch.context() as patch:
        # the commands import these when they run (a fast --help), so they are patched at their source
        patch.setattr("bayesnsi.run.run_candidates", _stub)
        patch.setattr("bayesnsi.selection.select", _stub)
        patch.setattr(bayesnsi.simulate, "simulate_case", _capped(bayesnsi.simulate.simulate_case))
        patch.setattr(bayesnsi.simulate, "undeclared_case", _capped(bayesnsi.simulate.undeclared_case))
        yield patch


def _grammar():
    """Subcommand -> ({flag taking a value: whether it is a number}, switches, choices of the positional)."""
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    grammar = {}
    for name, sub in commands.items():
        flags = [a for a in sub._actions if a.option_strings]
        positional = [c for a in sub._actions if not a.option_strings and a.choices for c in a.choices]
        grammar[name] = (
            {s: getattr(a.type, "__name__", "") in ("int", "float")
             for a in flags if a.nargs != 0 for s in a.option_strings},
            sorted(s for a in flags if a.nargs == 0 for s in a.option_strings),
            positional,
        )
    return grammar


GRAMMAR = _grammar()
_words = st.text(st.characters(codec="utf-8", exclude_characters="/~\x00"), max_size=8)  # no path outside
_numbers = (
    st.integers().map(str) | st.floats().map(repr)
    | st.sampled_from(["nan", "-nan", "inf", "-inf", "1e308", "1e999", "-1", "0", "2", "4", "0.5", "none", "None",
                       "9" * 30, "-" + "9" * 5000, "0x10", "1_000", " 3", "3 ", ""])
)
_paths = st.sampled_from([
    "sane.toml", "nodata.toml", "notconfig.csv", "adir", "adir/inside", "/dev/null", "missing.toml", "out", "out.csv",
    "adir/out.csv", "deep/er/out", "deep/er/out.csv", ".", "..", "", "sane.toml/x", "/dev/null/x.csv",
    "adir/inside/x.csv", "notconfig.csv/out",
])


@st.composite
def _argv(draw):
    """A well-formed call (often) of a real subcommand, with random tokens inserted or replaced."""
    command = draw(st.sampled_from(sorted(GRAMMAR)))
    valued, switches, choices = GRAMMAR[command]
    base = [command]
    if choices:
        base.append(draw(st.sampled_from(choices) | _words))
    elif command != "demo":
        base.append(draw(st.sampled_from(["sane.toml", "sane.toml"]) | _paths))
    outs = ["out.csv", "deep/er/out.csv", "adir/out.csv"] if command == "simulate" else ["out", "deep/er/out"]
    base += ["--out", draw(st.sampled_from(outs) | _paths)]
    token = (
        st.sampled_from(sorted(valued) + switches + ["--bogus", "-x", "--", "-h", "--help", "--debug"])
        | _numbers | _paths | _words | st.sampled_from(sorted(GRAMMAR))
    )
    for _ in range(draw(st.sampled_from([0, 0, 1, 2, 4]))):  # flags with a value, mostly a number for numbers
        flag = draw(st.sampled_from(sorted(valued)))
        base += [flag, draw(st.one_of(_numbers, _numbers, _paths, _words) if valued[flag] else _paths | _words)]
    base += draw(st.lists(st.sampled_from([s for s in switches if s not in ("-h", "--help")]), max_size=3))
    for _ in range(draw(st.sampled_from([0, 0, 0, 1, 2, 3]))):  # random tokens anywhere (often none)
        position = draw(st.integers(0, len(base)))
        if draw(st.booleans()) and position < len(base):
            base[position] = draw(token)
        else:
            base.insert(position, draw(token))
    return (["--debug"] if draw(st.integers(0, 9)) == 0 else []) + base


def _example_folder():
    """A fresh working folder with the inputs that :data:`_paths` name."""
    work = Path(tempfile.mkdtemp(dir=FOLDER)) / "work"
    (work / "adir").mkdir(parents=True)
    (work / "adir" / "inside").write_text("x")
    sane = {**_SANE, "data": {**_SANE["data"], "file": str(FOLDER / "data.csv")}}
    (work / "sane.toml").write_text(dump_config(sane))
    (work / "nodata.toml").write_text(dump_config({**_SANE, "data": {**_SANE["data"], "file": "none.csv"}}))
    (work / "notconfig.csv").write_text((FOLDER / "data.csv").read_text())
    return work


def _run_cli(argv):
    """``main(argv)`` in a fresh folder with the computations stubbed: exit code and stderr."""
    work = _example_folder()
    stdout, stderr = io.StringIO(), io.StringIO()
    try:
        with _cheap_commands() as patch, contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            patch.chdir(work)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)  # what the command says is judged by its exit
                try:
                    code = cli.main(argv)
                except SystemExit as stop:  # argparse: --help (0) or a usage error (2)
                    code = 0 if stop.code is None else stop.code
    finally:
        shutil.rmtree(work.parent, ignore_errors=True)
    return code, stderr.getvalue()


@pytest.fixture(scope="module", autouse=True)
def _warm_up():
    """Import every command and simulate once outside the per-example deadline."""
    _run_cli(["simulate", "two-dof", "--out", "w.csv", "--quiet"])
    _run_cli(["identify", "sane.toml", "--out", "w"])


@settings(max_examples=CACHE_EXAMPLES, deadline=5000)
@given(_argv())
def test_cli_exits_with_0_or_2_and_one_line(argv):
    code, stderr = _run_cli(argv)
    command = argv[1] if argv[0] == "--debug" and len(argv) > 1 else argv[0]
    why = "usage" if "usage:" in stderr else "reached the computation" if "stubbed out" in stderr else "refused"
    why = why if code else "help" if {"-h", "--help"} & set(argv) else "ran"
    event(f"exit {code}: {command if command in GRAMMAR else 'no command'}, {why}")
    assert code in (0, 2), (code, stderr)
    assert "internal error" not in stderr
    assert "--debug" in argv or "Traceback" not in stderr, stderr


def test_stubs_stop_a_valid_run_after_its_checks():
    code, stderr = _run_cli(["select", "sane.toml", "--out", "out", "--quiet"])
    assert code == 2 and "stubbed out by the fuzzer" in stderr
    code, stderr = _run_cli(["simulate", "two-dof", "--out", "out.csv", "--duration", "100", "--quiet"])
    assert code == 0 and stderr == ""


# ---------------------------------------------------------------------------------------------
# regressions found by the fuzzers


@pytest.mark.parametrize("options_class, key", [(LoopOptions, "threshold"), (EvidenceOptions, "reference_force_rms")])
def test_integer_beyond_every_float_is_a_config_error(options_class, key):
    with pytest.raises(ConfigError, match=key):  # was OverflowError (float() of the integer)
        options_class.from_mapping({key: 10**400})


def test_integer_too_long_to_print_is_a_config_error():
    with pytest.raises(ConfigError, match="too large to print"):  # was ValueError from repr()
        EvidenceOptions.from_mapping({"n_steps": 10**5000})
    with pytest.raises(ConfigError, match="beyond 64 bits"):  # dump_config wrote it; TOML cannot hold it
        dump_config({"seed": 2**63})


def test_config_with_an_integer_too_long_to_read_is_a_config_error(tmp_path):
    path = tmp_path / "long.toml"
    path.write_text("seed = 1" + "0" * 5000 + "\n")
    with pytest.raises(ConfigError, match="not valid TOML"):  # was ValueError from int()
        load_config(path)


@pytest.mark.parametrize("argv", [["identify", "9" * 300, "--out", "out"], ["demo", "--out", "a" * 300],
                                  ["simulate", "two-dof", "--out", "a" * 300 + ".csv"]])
def test_path_too_long_for_the_system_is_bad_input(argv):
    code, stderr = _run_cli(argv)  # was exit 74, "I/O error: free space or fix permissions"
    assert code == 2 and "choose a shorter path" in stderr and len(stderr) < 300


@pytest.mark.parametrize("out", ["/dev/null/x.csv", "adir/inside/x.csv"])
def test_simulate_into_a_folder_that_is_a_file_is_bad_input(out):
    code, stderr = _run_cli(["simulate", "two-dof", "--out", out])  # was exit 74, "I/O error"
    assert code == 2 and "cannot create the folder" in stderr
