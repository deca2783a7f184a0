"""Experiment configuration: TOML file -> frozen :class:`ExperimentConfig` (SPEC section 9).

Layout (everything but ``[data]`` inputs/outputs and ``[[candidates]]`` has a default)::

    seed = 0                                  # optional; or in [evidence]

    [data]
    file = "two_dof.csv"                      # relative to this config file's folder; .csv (or any
                                              # other text), .mat (v5 or v7.3), .h5/.hdf5, .uff/.unv
    fs = 100.0                                # Hz; omit to derive it from the time column "t"
    inputs = { f2 = 2 }                       # force column -> DOF (numbered from 1)
    outputs = { x1 = 1, x2 = 2 }              # displacement column -> DOF
    velocities = { v1 = 1, v2 = 2 }           # optional, same DOFs as outputs
    accelerations = { a1 = 1 }                # optional; stored only, unless integrate is given
    estimation = [0, 800]                     # optional sample window [start, stop) of the file
    remove_mean = false                       # optional
    decimate = 1                              # optional integer factor (anti-aliased)

    # accelerations only: instead of outputs/velocities
    # accelerations = { a1 = 1, a2 = 2 }
    # integrate = { band_hz = [1.0, 40.0] }   # + method, taper, filter_inputs, ... (DataSpec)

    [nsi]                                     # all optional
    block_rows = 40
    order = "auto"                            # or an integer
    band_hz = [1.0, 10.0]                     # "band" is accepted as an alias
    velocity_method = "fourth"                # "central", "fourth", "sixth"
    bd_method = "robust"                      # or "output-error"
    max_order = 40
    zero_feedthrough = true

    [[candidates]]
    name = "quadratic damping"
    prior = 1.0                               # optional, unnormalised
    terms = [{ expr = "v1*abs(v1)", at = 1, prior_scale = 50.0 }]   # at = [j, k]: element j-k

    [[validation]]                            # optional, never used for estimation
    name = "tail"
    start = 800
    stop = 1000                               # or: file = "other.csv" (same columns)

    [evidence]                                # optional, numbers/strings/bools (and lists of them)
    [meta]                                    # optional, free-form notes (e.g. the true values)

Every mistake raises :class:`~bayesnsi.exceptions.ConfigError` naming the file, the section and
key, what was expected, what was found and what to do. Nothing in the file is evaluated: the
TOML is parsed by :mod:`tomllib` and expressions by :func:`bayesnsi.models.parse_expression`.
"""

from __future__ import annotations

import difflib
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..exceptions import ConfigError, ExpressionError
from ..models import CandidateModel, Term
from ..options import EvidenceOptions, LoopOptions, NSIOptions
from ..preprocess import INTEGRATION_METHODS
from . import _toml

__all__ = [
    "DataSpec",
    "IntegrationSpec",
    "ValidationSegment",
    "ExperimentConfig",
    "load_config",
    "dump_config",
]

_TOP_KEYS = ("seed", "data", "nsi", "candidates", "validation", "evidence", "diagnose", "meta")
_DATA_KEYS = (
    "file", "fs", "time_column", "inputs", "outputs", "velocities", "accelerations", "estimation", "remove_mean",
    "integrate", "decimate",
)
_INTEGRATE_KEYS = ("band_hz", "method", "taper", "filter_inputs", "filter_order", "detrend_order")
_CANDIDATE_KEYS = ("name", "prior", "terms")
_TERM_KEYS = ("expr", "at", "prior_scale")
_VALIDATION_KEYS = ("name", "start", "stop", "file")
_MISSING = object()


@dataclass(frozen=True)
class IntegrationSpec:
    """How displacements and velocities are derived from accelerations (``[data] integrate``).

    Written as an inline table, e.g. ``integrate = { band_hz = [1.0, 40.0] }``; only
    ``band_hz`` is required. The arguments are those of
    :func:`bayesnsi.preprocess.integrate_acceleration`, whose docstring states the gain and
    phase of each method and its limits.

    Parameters
    ----------
    band_hz : (float, float)
        ``[f_lo, f_hi]`` [Hz], ``0 < f_lo < f_hi``: everything below ``f_lo`` is removed (drift
        and true motion alike); ``f_hi`` is a low-pass, none when ``f_hi >= fs/2``. Put ``f_lo``
        below the lowest mode (a factor 2 or more) and ``[nsi] band_hz`` inside this band.
    method : {"frequency", "time"}
        Frequency-domain division by jω, (jω)² with a zero-phase raised-cosine band window
        (default), or trapezoid rule + polynomial detrend + zero-phase Butterworth high-pass.
    taper : float
        Relative width of the raised-cosine transitions (frequency method), in [0, 1).
    filter_inputs : bool
        Filter the forces with the same band weighting (:func:`bayesnsi.preprocess.band_filter`),
        so that input and output carry one filter (default true). Without it the outputs miss
        the content below ``f_lo`` that the forces still have: on the two-DOF case this made
        the identification fail.
    filter_order : int
        Butterworth order (time method).
    detrend_order : int
        Polynomial order removed after each integration (time method).
    """

    band_hz: tuple[float, float]
    method: str = "frequency"
    taper: float = 0.5
    filter_inputs: bool = True
    filter_order: int = 4
    detrend_order: int = 2


@dataclass(frozen=True)
class DataSpec:
    """Where the measurements are and which column is what (``[data]``).

    The file format follows the extension of ``file``: ``.mat`` (MATLAB v5 via scipy, v7.3
    via h5py), ``.h5``/``.hdf5``, ``.uff``/``.unv`` (Universal File Format dataset 58, via
    pyuff); anything else is read as CSV text. "Column" means a CSV column, a MAT/HDF5
    variable (a vector, 1×N or N×1), or a UFF58 time record, found by its ``id1`` text or,
    failing that, by a key ``"node:dir"`` such as ``"2:+Z"`` (response node and direction;
    directions X, Y, Z, RX, RY, RZ with an optional sign, or the numeric UFF code). See
    :mod:`bayesnsi.io.measurements` for each format's rules.

    Processing order on load (:func:`bayesnsi.io.load_signals`): each window (the estimation
    window, each validation segment) is cut from the file first - so no sample outside it
    influences it - then integrated (``integrate``), then decimated (``decimate``), then the
    means are removed (``remove_mean``). Sample indices (``estimation``, validation ``start``/
    ``stop``) always count samples *of the file*; a decimated window ``[start, stop)`` holds
    the file samples ``start, start + q, ...`` below ``stop``.

    Accelerations only: give ``accelerations`` and ``integrate`` and leave out ``outputs`` and
    ``velocities``; displacements and velocities are then derived on load, named ``x<dof>``
    (``outputs`` holds that map, so the rest of the package sees displacement channels).

    Parameters
    ----------
    file : Path
        Measurement file, absolute (resolved relative to the config file's folder).
    fs : float or None
        Sampling frequency of the file [Hz]; None means: take it from the file (time column or
        variable, ``fs`` variable of a MAT/HDF5 file, ``abscissa_inc`` of UFF records). When
        both are present they must agree (see :mod:`bayesnsi.io.measurements`).
    inputs : dict of str to int
        Force column -> DOF (1-based), in the order written in the config.
    outputs : dict of str to int
        Displacement column -> DOF, in the order written in the config (with ``integrate``: the
        derived channels ``x<dof>`` in the order of ``accelerations``).
    velocities : dict of str to int or None
        Measured velocity column -> DOF; the same DOFs as ``outputs``.
    accelerations : dict of str to int
        Acceleration column -> DOF; recorded only, unless ``integrate`` is given.
    estimation : (int, int) or None
        Half-open sample window ``[start, stop)`` used for estimation; None: the whole record.
    remove_mean : bool
        Subtract each channel's mean over the estimation window (also from validation data).
    time_column : str
        Name of the time column [s], read when ``fs`` is None (and checked when present).
    integrate : IntegrationSpec or None
        Derive displacements and velocities from ``accelerations`` (``[data] integrate``).
    decimate : int
        Anti-aliased down-sampling factor q >= 1 (:func:`bayesnsi.preprocess.decimate`, zero-phase
        FIR): the signals have ``fs / q``. Keep the modes below ~0.75 of the new Nyquist frequency.
    """

    file: Path
    fs: float | None
    inputs: dict[str, int]
    outputs: dict[str, int]
    velocities: dict[str, int] | None = None
    accelerations: dict[str, int] = field(default_factory=dict)
    estimation: tuple[int, int] | None = None
    remove_mean: bool = False
    time_column: str = "t"
    integrate: IntegrationSpec | None = None
    decimate: int = 1

    @property
    def signal_fs(self) -> float | None:
        """Sampling frequency of the loaded signals [Hz]: ``fs / decimate`` (None if fs is)."""
        return None if self.fs is None else self.fs / self.decimate

    @property
    def dofs(self) -> tuple[int, ...]:
        """Sorted DOFs that are forced or measured."""
        return tuple(sorted(set(self.inputs.values()) | set(self.outputs.values())))


@dataclass(frozen=True)
class ValidationSegment:
    """A stretch of data kept for validation only (``[[validation]]``).

    Parameters
    ----------
    name : str
        Label used in results.json.
    start, stop : int or None
        Half-open sample window ``[start, stop)``; None for the start or end of the record.
        Always given for segments of the estimation file.
    file : Path or None
        Another CSV with the same columns; None: the estimation file.
    """

    name: str
    start: int | None
    stop: int | None
    file: Path | None = None


@dataclass(frozen=True)
class ExperimentConfig:
    """A validated experiment configuration.

    Parameters
    ----------
    path : Path
        The config file, absolute.
    data : DataSpec
    nsi : NSIOptions
        ``[nsi]``.
    candidates : tuple of CandidateModel
    validation : tuple of ValidationSegment
    evidence : EvidenceOptions
        ``[evidence]`` (its ``seed`` is the config's ``seed``).
    loop : LoopOptions
        ``[diagnose]``: the guards and search of the loop (its seed is the config's ``seed``).
    seed : int
        Seed of every random generator of the run.
    raw : dict
        The parsed TOML, to record the settings with the results.
    meta : dict
        The free-form ``[meta]`` table (empty if absent).
    """

    path: Path
    data: DataSpec
    nsi: NSIOptions
    candidates: tuple[CandidateModel, ...]
    validation: tuple[ValidationSegment, ...]
    evidence: EvidenceOptions
    loop: LoopOptions
    seed: int
    raw: dict[str, Any]
    meta: dict[str, Any] = field(default_factory=dict)


def load_config(path: str | os.PathLike, check_files: bool = True) -> ExperimentConfig:
    """Read and validate an experiment configuration (TOML, SPEC section 9).

    Parameters
    ----------
    path : str or path-like
        The TOML file.
    check_files : bool
        Check that the data and validation files exist (their contents are read later, by
        :func:`bayesnsi.io.load_signals`).

    Returns
    -------
    ExperimentConfig

    Raises
    ------
    ConfigError
        On any mistake: unreadable TOML, unknown keys, wrong types, missing data mapping,
        bad expressions, terms on unmeasured DOFs, overlapping validation segments, missing files.
    """
    try:
        path = Path(path).expanduser().resolve()
    except RuntimeError as exc:  # "~user" that names no user
        raise ConfigError(f"config path {str(path)!r}: {exc}; write the path without '~'") from exc
    if not path.is_file():
        raise ConfigError(f"config file {path} not found; check the path (relative paths start at the working folder)")
    try:
        with open(path, "rb") as fh:
            raw = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc}); fix the syntax at that line") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text ({exc}); save the config as UTF-8") from exc
    top = _Where(path, "top level")
    _check_keys(raw, _TOP_KEYS, top)
    data = _parse_data(raw.get("data", _MISSING), _Where(path, "[data]"), check_files)
    nsi = _parse_nsi(raw.get("nsi", {}), _Where(path, "[nsi]"), data)
    candidates = _parse_candidates(raw.get("candidates", _MISSING), path, data)
    validation = _parse_validation(raw.get("validation", []), path, data, check_files)
    evidence, seed = _parse_evidence(raw, path)
    loop = _options(LoopOptions, raw.get("diagnose", {}), _Where(path, "[diagnose]"), seed=seed)
    meta = raw.get("meta", {})
    if not isinstance(meta, dict):
        raise _Where(path, "top level").error("meta", "a table [meta]", meta, "write notes as [meta] key = value")
    return ExperimentConfig(
        path=path, data=data, nsi=nsi, candidates=candidates, validation=validation,
        evidence=evidence, loop=loop, seed=seed, raw=raw, meta=meta,
    )


def dump_config(config: Mapping[str, Any]) -> str:
    """Write a configuration dict as TOML text (the subset :func:`load_config` reads).

    Parameters
    ----------
    config : mapping
        Plain values: str, bool, int, float, path-like, lists/tuples, and mappings. At the top
        level a mapping becomes a ``[table]`` and a non-empty list of mappings an array of
        tables ``[[name]]``; deeper mappings become inline tables, and lists of mappings
        inside a table are written one inline table per line.

    Returns
    -------
    str
        TOML text with ``tomllib.loads(dump_config(d)) == d`` for such dicts (tuples and paths
        come back as lists and strings; NaN never compares equal).

    Raises
    ------
    ConfigError
        For values TOML cannot hold (None, other objects), naming the key.

    Examples
    --------
    >>> print(dump_config({"seed": 1, "nsi": {"order": "auto"}}), end="")
    seed = 1
    <BLANKLINE>
    [nsi]
    order = "auto"
    """
    return _toml.dumps(config)


# ---------------------------------------------------------------------------------------------
# error messages


class _Where:
    """A place in the config file, to build messages: file, section, key, expected, found, fix."""

    def __init__(self, path: Path, section: str):
        self.path = path
        self.section = section

    def error(self, key: str | None, expected: str, found: Any = _MISSING, fix: str = "") -> ConfigError:
        place = f"{self.path}: {self.section}" + (f" {key}" if key else "")
        found_text = "nothing (the key is missing)" if found is _MISSING else _describe(found)
        return ConfigError(f"{place}: expected {expected}, found {found_text}" + (f"; {fix}" if fix else ""))

    def problem(self, key: str | None, message: str) -> ConfigError:
        place = f"{self.path}: {self.section}" + (f" {key}" if key else "")
        return ConfigError(f"{place}: {message}")


def _describe(value: Any) -> str:
    kind = {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array",
            dict: "a table"}.get(type(value), type(value).__name__)
    text = repr(value)
    if len(text) > 80:
        text = text[:77] + "..."
    return f"{text} ({kind})"


def _check_keys(table: Mapping, allowed: tuple[str, ...], where: _Where) -> None:
    unknown = [k for k in table if k not in allowed]
    if not unknown:
        return
    hints = []
    for key in unknown:
        close = difflib.get_close_matches(key, allowed, n=1)
        hints.append(f"{key!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    raise where.problem(
        None, f"unknown key(s) {', '.join(hints)}; allowed keys are: {', '.join(allowed)}. "
        "Fix the spelling or remove the key"
    )


# ---------------------------------------------------------------------------------------------
# typed getters


def _int(table: Mapping, key: str, where: _Where, default: Any = _MISSING, minimum: int | None = None):
    value = table.get(key, default)
    if value is _MISSING:
        raise where.error(key, "an integer", fix=f"add {key} = <integer>")
    if value is None and default is None:
        return None
    if not isinstance(value, int) or isinstance(value, bool):
        raise where.error(key, "an integer", value, "write it without quotes or decimal point")
    if minimum is not None and value < minimum:
        raise where.error(key, f"an integer >= {minimum}", value)
    return value


def _number(table: Mapping, key: str, where: _Where, default: Any = _MISSING, positive: bool = False):
    value = table.get(key, default)
    if value is _MISSING:
        raise where.error(key, "a number", fix=f"add {key} = <number>")
    if value is None:
        return None
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise where.error(key, "a finite number", value, "write it without quotes, e.g. 100.0")
    if positive and value <= 0:
        raise where.error(key, "a positive number", value)
    return float(value)


def _bool(table: Mapping, key: str, where: _Where, default: bool) -> bool:
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise where.error(key, "true or false", value, "write true or false without quotes")
    return value


def _choice(table: Mapping, key: str, where: _Where, choices: tuple[str, ...], default: str) -> str:
    value = table.get(key, default)
    if not isinstance(value, str) or value not in choices:
        raise where.error(key, f"one of {', '.join(map(repr, choices))}", value)
    return value


def _text(table: Mapping, key: str, where: _Where, default: Any = _MISSING) -> str:
    value = table.get(key, default)
    if value is _MISSING:
        raise where.error(key, "a string", fix=f'add {key} = "..."')
    if not isinstance(value, str) or not value.strip():
        raise where.error(key, "a non-empty string", value, "put the text in double quotes")
    return value


def _window(value: Any, where: _Where, key: str) -> tuple[int, int]:
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, int) and not isinstance(v, bool) for v in value))
    if not ok or not 0 <= value[0] < value[1]:
        raise where.error(key, "[start, stop] sample indices with 0 <= start < stop (stop excluded)", value)
    return value[0], value[1]


# ---------------------------------------------------------------------------------------------
# sections


def _parse_data(table: Any, where: _Where, check_files: bool) -> DataSpec:
    if table is _MISSING:
        raise where.problem(None, 'the [data] section is missing; add [data] with file = "...", fs, inputs and outputs')
    if not isinstance(table, dict):
        raise where.error(None, "a table [data]", table)
    _check_keys(table, _DATA_KEYS, where)
    file = _resolve_file(_text(table, "file", where), where, "file", check_files)
    fs = _number(table, "fs", where, None, positive=True)
    time_column = _text(table, "time_column", where, "t")
    inputs = _dof_map(table, "inputs", where, required=True)
    accelerations = _dof_map(table, "accelerations", where, required=False) or {}
    integrate = _parse_integrate(table, where, fs, accelerations)
    if integrate is not None:
        for key in ("outputs", "velocities"):
            if key in table:
                raise where.problem(
                    key, "with integrate, displacements and velocities are derived from accelerations; remove "
                    f"{key} (or remove integrate to use measured displacements)"
                )
        outputs = velocities = None
    else:
        if "outputs" not in table and accelerations:
            raise where.error(
                "outputs", "a table mapping displacement columns to DOFs",
                fix="add outputs = { column_name = 1 }, or derive displacements from the accelerations with "
                "integrate = { band_hz = [f_lo, f_hi] }",
            )
        outputs = _dof_map(table, "outputs", where, required=True)
        velocities = _dof_map(table, "velocities", where, required=False)
    if velocities is not None and sorted(velocities.values()) != sorted(outputs.values()):
        raise where.error(
            "velocities", f"the same DOFs as outputs {sorted(outputs.values())}", velocities,
            "give one velocity column per displacement column, or drop velocities to derive them",
        )
    _check_columns_unique(where, time_column if fs is None else None, inputs, outputs, velocities, accelerations)
    if integrate is not None:
        outputs = {f"x{dof}": dof for dof in accelerations.values()}
    estimation = table.get("estimation")
    if estimation is not None:
        estimation = _window(estimation, where, "estimation")
    decimate = _int(table, "decimate", where, 1, minimum=1)
    return DataSpec(
        file=file, fs=fs, inputs=inputs, outputs=outputs, velocities=velocities,
        accelerations=accelerations, estimation=estimation,
        remove_mean=_bool(table, "remove_mean", where, False), time_column=time_column,
        integrate=integrate, decimate=decimate,
    )


def _parse_integrate(table: Mapping, where: _Where, fs: float | None, accelerations) -> IntegrationSpec | None:
    value = table.get("integrate")
    if value is None:
        return None
    key = "integrate"
    example = "integrate = { band_hz = [f_lo, f_hi] }"
    if not isinstance(value, dict):
        raise where.error(key, "an inline table", value, f"write {example}")
    if not accelerations:
        raise where.problem(
            key, "integrate derives displacements from accelerations, but no accelerations are given; add "
            "accelerations = { column_name = 1 }"
        )
    here = _Where(where.path, f"{where.section} integrate")
    _check_keys(value, _INTEGRATE_KEYS, here)
    band = value.get("band_hz", _MISSING)
    ok = (isinstance(band, list) and len(band) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in band))
    if not ok or not 0 < band[0] < band[1]:
        raise here.error(
            "band_hz", "[f_lo, f_hi] in Hz with 0 < f_lo < f_hi (content below f_lo is removed; f_hi >= fs/2: "
            "no low-pass)", band,
        )
    if fs is not None and band[0] >= fs / 2:
        raise here.error("band_hz", f"f_lo below the Nyquist frequency {fs / 2:g} Hz", band)
    defaults = IntegrationSpec(band_hz=(1.0, 2.0))
    taper = _number(value, "taper", here, defaults.taper)
    if not 0 <= taper < 1:
        raise here.error("taper", "a number in [0, 1)", taper)
    return IntegrationSpec(
        band_hz=(float(band[0]), float(band[1])),
        method=_choice(value, "method", here, INTEGRATION_METHODS, defaults.method),
        taper=taper,
        filter_inputs=_bool(value, "filter_inputs", here, defaults.filter_inputs),
        filter_order=_int(value, "filter_order", here, defaults.filter_order, minimum=1),
        detrend_order=_int(value, "detrend_order", here, defaults.detrend_order, minimum=0),
    )


def _resolve_file(name: str, where: _Where, key: str, check_files: bool) -> Path:
    if not name.strip() or "\x00" in name:
        raise where.error(key, "a file name (relative to the config file's folder)", name)
    file = _expand_home(Path(name), where, key)
    if not file.is_absolute():
        file = where.path.parent / file
    try:
        file = file.resolve()
    except (OSError, RuntimeError, ValueError) as exc:  # e.g. a symlink loop
        raise where.problem(key, f"cannot resolve the path {name!r} ({exc}); fix the file name") from exc
    if check_files and not file.is_file():
        raise where.problem(
            key, f"data file {name!r} not found (looked for {file}); paths are relative to the "
            "config file's folder - fix the name or move the file there"
        )
    return file


def _expand_home(path: Path, where: _Where, key: str) -> Path:
    """``~`` and ``~user`` expanded; a user that does not exist is a ConfigError (not RuntimeError)."""
    try:
        return path.expanduser()
    except RuntimeError as exc:
        raise where.problem(key, f"cannot expand {str(path)!r} ({exc}); write the path without '~'") from exc


def _dof_map(table: Mapping, key: str, where: _Where, required: bool) -> dict[str, int] | None:
    value = table.get(key, _MISSING)
    example = f"{key} = {{ column_name = 1 }}"
    if value is _MISSING:
        if required:
            raise where.error(key, "a table mapping column names to DOFs", fix=f"add {example}")
        return None
    if not isinstance(value, dict) or (required and not value):
        raise where.error(key, "a non-empty table mapping column names to DOFs", value, f"write {example}")
    seen: dict[int, str] = {}
    for column, dof in value.items():
        if not isinstance(dof, int) or isinstance(dof, bool) or dof < 1:
            raise where.error(f"{key}.{column}", "a DOF number >= 1 (DOFs are numbered from 1)", dof)
        if dof in seen:
            raise where.problem(
                key, f"DOF {dof} is mapped twice (columns {seen[dof]!r} and {column!r}); map each DOF to one column"
            )
        seen[dof] = column
    return dict(value)


def _check_columns_unique(where: _Where, time_column: str | None, *maps) -> None:
    names = ("inputs", "outputs", "velocities", "accelerations")
    used: dict[str, str] = {time_column: "time_column"} if time_column else {}
    for role, mapping in zip(names, maps):
        for column in mapping or {}:
            if column in used:
                raise where.problem(
                    role, f"column {column!r} is already used as {used[column]}; each column has one role"
                )
            used[column] = role


def _parse_nsi(table: Any, where: _Where, data: DataSpec) -> NSIOptions:
    if isinstance(table, dict) and "band" in table:
        if "band_hz" in table:
            raise where.problem("band", "band and band_hz are the same setting; keep only band_hz")
        table = {("band_hz" if k == "band" else k): v for k, v in table.items()}
    options = _options(NSIOptions, table, where)
    if options.order != "auto" and options.order > options.block_rows * len(data.outputs):
        limit = options.block_rows * len(data.outputs)
        raise where.error(
            "order", f"at most block_rows x outputs = {options.block_rows} x {len(data.outputs)} = {limit}",
            options.order, "raise block_rows or lower order",
        )
    fs = data.signal_fs
    for key in ("band_hz", "refine_poles"):
        band = getattr(options, key)
        if band is not None and fs is not None and band[1] > fs / 2:
            raise where.error(key, f"a band below the Nyquist frequency {fs / 2:g} Hz", list(band))
    return options


def _options(kind: type, table: Any, where: _Where, **fixed: Any):
    """Build an options object from a config table; errors carry the file and section."""
    if not isinstance(table, dict):
        raise where.error(None, f"a table [{kind.SECTION}]", table)
    _check_keys(table, tuple(k for k in kind.names() if k not in fixed), where)
    try:
        return kind.from_mapping(table, **fixed)
    except ConfigError as exc:
        raise ConfigError(f"{where.path}: {exc}") from None


def _parse_candidates(items: Any, path: Path, data: DataSpec) -> tuple[CandidateModel, ...]:
    top = _Where(path, "[[candidates]]")
    how = 'add at least one [[candidates]] table with name = "..." and terms = [{ expr = "...", at = 1 }]'
    if items is _MISSING or items == []:
        raise top.problem(None, f"no candidate models are given; {how}")
    if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
        raise top.error(None, "an array of tables written [[candidates]] (double brackets)", items, how)
    models, names = [], set()
    for index, item in enumerate(items, start=1):
        where = _Where(path, f"[[candidates]] #{index}")
        _check_keys(item, _CANDIDATE_KEYS, where)
        name = _text(item, "name", where)
        where = _Where(path, f"[[candidates]] #{index} ({name!r})")
        if name in names:
            raise where.problem("name", f"candidate name {name!r} is used twice; give each candidate its own name")
        names.add(name)
        prior = _number(item, "prior", where, 1.0, positive=True)
        terms, scales = _parse_terms(item, where, data)
        try:
            models.append(CandidateModel(name=name, terms=terms, prior=prior, coefficient_prior_scales=scales))
        except (ConfigError, ExpressionError) as exc:
            raise where.problem(None, f"{exc}; fix the terms of this candidate") from exc
    return tuple(models)


def _parse_terms(item: Mapping, where: _Where, data: DataSpec) -> tuple[tuple[Term, ...], tuple]:
    value = item.get("terms", _MISSING)
    if value is _MISSING or not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
        raise where.error(
            "terms", 'an array of tables like [{ expr = "v1*abs(v1)", at = 1 }]', value,
            "write terms = [] for a linear model",
        )
    measured = set(data.outputs.values())
    located = set(data.dofs)
    terms, scales = [], []
    for index, entry in enumerate(value, start=1):
        key = f"terms[{index}]"
        here = _Where(where.path, f"{where.section} {key}")
        _check_keys(entry, _TERM_KEYS, here)
        if "expr" not in entry:
            raise here.error("expr", 'an expression string such as "v1*abs(v1)"', fix='add expr = "..."')
        expr = _text(entry, "expr", here)
        if "at" not in entry:
            raise here.error("at", "a DOF (at = 1) or a pair of DOFs (at = [1, 2])", fix="add at = <DOF>")
        try:
            term = Term(expr, entry["at"])
        except ExpressionError as exc:
            raise where.problem(f"{key}.expr", f"{exc}") from exc
        unmeasured = sorted(set(term.expr.dofs) - measured)
        if unmeasured:
            raise where.problem(
                f"{key}.expr", f"{expr!r} reads DOF(s) {unmeasured}, but outputs measure only DOFs "
                f"{sorted(measured)}; use measured DOFs or add the missing displacement columns to [data] outputs"
            )
        outside = sorted(set(term.at) - located)
        if outside:
            raise where.problem(
                f"{key}.at", f"the term acts at DOF(s) {outside}, which are neither forced nor measured "
                f"(known DOFs: {sorted(located)}), so its coefficient cannot be identified (SPEC section 4); "
                "place it at a measured DOF"
            )
        terms.append(term)
        scales.append(_number(entry, "prior_scale", here, None, positive=True))
    return tuple(terms), tuple(scales)


def _parse_validation(items: Any, path: Path, data: DataSpec, check_files: bool) -> tuple[ValidationSegment, ...]:
    top = _Where(path, "[[validation]]")
    if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
        raise top.error(None, "an array of tables written [[validation]] (double brackets)", items)
    segments, names = [], set()
    for index, item in enumerate(items, start=1):
        where = _Where(path, f"[[validation]] #{index}")
        _check_keys(item, _VALIDATION_KEYS, where)
        name = _text(item, "name", where)
        if name in names:
            raise where.problem("name", f"validation name {name!r} is used twice; give each segment its own name")
        names.add(name)
        file = _resolve_file(_text(item, "file", where), where, "file", check_files) if "file" in item else None
        start = _int(item, "start", where, None if file else _MISSING, minimum=0)
        stop = _int(item, "stop", where, None if file else _MISSING, minimum=1)
        if start is not None and stop is not None and start >= stop:
            raise where.error("stop", f"an index greater than start = {start}", stop)
        if file is None or file == data.file:
            _check_no_overlap(where, name, start, stop, data.estimation)
        segments.append(ValidationSegment(name=name, start=start, stop=stop, file=file))
    return tuple(segments)


def _check_no_overlap(where, name, start, stop, estimation) -> None:
    if estimation is None:
        raise where.problem(
            None, f"segment {name!r} [{start}, {stop}) is in the data file, but the estimation window is the "
            "whole record by default; set [data] estimation = [start, stop] to a window that excludes it"
        )
    lo = 0 if start is None else start
    hi = math.inf if stop is None else stop
    if lo < estimation[1] and estimation[0] < hi:
        raise where.problem(
            None, f"segment {name!r} [{start}, {stop}) overlaps the estimation window "
            f"[{estimation[0]}, {estimation[1]}); validation data must never be used for estimation - "
            "move the segment or shrink [data] estimation"
        )


def _parse_evidence(raw: Mapping, path: Path) -> tuple[EvidenceOptions, int]:
    where = _Where(path, "[evidence]")
    table = raw.get("evidence", {})
    if not isinstance(table, dict):
        raise where.error(None, "a table [evidence]", table)
    top = _Where(path, "top level")
    seeds = {}
    if "seed" in raw:
        seeds["top"] = _int(raw, "seed", top, minimum=0)
    if "seed" in table:
        seeds["evidence"] = _int(table, "seed", where, minimum=0)
    if len(set(seeds.values())) > 1:
        raise top.problem("seed", f"seed = {seeds['top']} disagrees with [evidence] seed = {seeds['evidence']}; keep one")
    settings = {k: v for k, v in table.items() if k != "seed"}
    _check_keys(settings, (*EvidenceOptions.names(), "seed"), where)
    return _options(EvidenceOptions, settings, where), next(iter(seeds.values()), 0)
