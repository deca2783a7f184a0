"""The sections of an experiment configuration: ``[data]``, ``[nsi]``, ``[[candidates]]`` and
``[evidence]``, each checked and turned into its typed object (``[[validation]]``: :mod:`._config_validation`)."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

from ..exceptions import BayesNSIWarning, ConfigError, ExpressionError
from ..models import CandidateModel, Term
from ..options import EvidenceOptions, NSIOptions
from ..preprocess import INTEGRATION_METHODS
from ..signals import MAX_FS, MIN_FS
from ._config_fields import (
    MISSING,
    Where,
    build_options,
    check_keys,
    check_name,
    get_bool,
    get_choice,
    get_int,
    get_number,
    get_text,
    get_window,
)
from ._config_files import check_files_cover, parse_files
from ._specs import DataSpec, IntegrationSpec

__all__ = [
    "MAX_CONFIG_CANDIDATES", "TOO_MANY", "parse_candidates", "parse_data", "parse_evidence", "parse_integrate",
    "parse_nsi", "resolve_file",
]

MAX_CONFIG_CANDIDATES = 10_000
"""Most ``[[candidates]]`` tables accepted in one configuration file (larger databases are built
in code, e.g. with :func:`bayesnsi.run.dictionary_candidates`)."""

TOO_MANY = "build large candidate databases in code (bayesnsi.run.dictionary_candidates)"
_DATA_KEYS = tuple(f.name for f in dataclasses.fields(DataSpec))
_INTEGRATE_KEYS = tuple(f.name for f in dataclasses.fields(IntegrationSpec))
_CANDIDATE_KEYS = ("name", "prior", "terms")
_TERM_KEYS = ("expr", "at", "prior_scale")
_BAND_KEYS = tuple(f.name for f in dataclasses.fields(NSIOptions) if f.metadata.get("kind") == "band")


def parse_data(table: Any, where: Where, check_files: bool) -> DataSpec:
    """The ``[data]`` table as a :class:`DataSpec` (files resolved against the config's folder)."""
    if table is MISSING:
        raise where.problem(None, 'the [data] section is missing; add [data] with file = "...", fs, inputs and outputs')
    if not isinstance(table, dict):
        raise where.error(None, "a table [data]", table)
    check_keys(table, _DATA_KEYS, where)
    files = parse_files(table, where, lambda name, key: resolve_file(name, where, key, check_files))
    if not files and "file" not in table:
        raise where.error("file", "the measurement file", fix='add file = "data.csv", or files = { u = "u.csv", '
                          'y = "y.csv" } for one file per column (data shipped as separate channels)')
    file = next(iter(files.values())) if files else resolve_file(
        get_text(table, "file", where), where, "file", check_files)
    fs = get_number(table, "fs", where, None, positive=True)
    if fs is not None and not MIN_FS <= fs <= MAX_FS:
        raise where.error("fs", f"a sampling frequency in [{MIN_FS:g}, {MAX_FS:g}] Hz", fs)
    if files and fs is None:
        raise where.error("fs", "the sampling frequency in Hz", fix="files of single channels carry no time column")
    time_column = check_name(get_text(table, "time_column", where, "t"), where, "time_column")
    inputs = cast(dict[str, int], _dof_map(table, "inputs", where, required=True))
    accelerations = _dof_map(table, "accelerations", where, required=False) or {}
    velocities = _dof_map(table, "velocities", where, required=False)
    integrate = parse_integrate(table, where, fs, accelerations, velocities)
    if integrate is not None:  # displacements (and velocities) derived from the sensors' signals
        sensors = "accelerations" if accelerations else "velocities"
        for key in ("outputs", "velocities") if accelerations else ("outputs",):
            if key in table:
                raise where.problem(
                    key, f"with integrate, displacements{' and velocities' if accelerations else ''} are derived "
                    f"from the {sensors}; remove {key} (or remove integrate to use measured displacements)"
                )
        outputs: dict[str, int] = {}
    else:
        if "outputs" not in table and (accelerations or velocities):
            sensors = "accelerations" if accelerations else "velocities"
            raise where.error(
                "outputs", "a table mapping displacement columns to DOFs",
                fix=f"add outputs = {{ column_name = 1 }}, or derive displacements from the {sensors} with "
                "integrate = { band_hz = [f_lo, f_hi] }",
            )
        outputs = cast(dict[str, int], _dof_map(table, "outputs", where, required=True))
    if integrate is None and velocities is not None and sorted(velocities.values()) != sorted(outputs.values()):
        raise where.error(
            "velocities", f"the same DOFs as outputs {sorted(outputs.values())}", velocities,
            "give one velocity column per displacement column, or drop velocities to derive them",
        )
    _check_columns_unique(where, time_column if fs is None else None, inputs, outputs, velocities, accelerations)
    if files:
        check_files_cover(files, [*inputs, *outputs, *(velocities or {}), *accelerations], where)
    if integrate is not None:
        outputs = {f"x{dof}": dof for dof in (accelerations or cast(dict[str, int], velocities)).values()}
    estimation = table.get("estimation")
    if estimation is not None:
        estimation = get_window(estimation, where, "estimation")
    decimate = get_int(table, "decimate", where, 1, minimum=1)
    period = get_int(table, "period", where, None, minimum=2)
    if period is not None and period % decimate:
        raise where.error("period", f"a multiple of decimate ({decimate}) samples", period)
    realisations = get_int(table, "realisations", where, 1, minimum=1)
    transient = get_int(table, "transient_periods", where, 0, minimum=0)
    if period is None and (realisations > 1 or transient):
        raise where.problem("realisations" if realisations > 1 else "transient_periods",
                            "needs the period of the test: add period = <samples per period>")
    scale = _scale_map(table, where, [*inputs, *outputs, *(velocities or {}), *accelerations])
    units = _units_map(table, where, [*inputs, *outputs, *(velocities or {}), *accelerations])
    return DataSpec(
        file=file, fs=fs, inputs=inputs, outputs=outputs, velocities=velocities,
        accelerations=accelerations, estimation=estimation,
        remove_mean=get_bool(table, "remove_mean", where, False), time_column=time_column, period=period,
        realisations=realisations, transient_periods=transient, integrate=integrate, decimate=decimate, scale=scale,
        units=units, files=files,
    )


def _column_map(table: Mapping, where: Where, columns: list[str], key: str, example: str, expected: str,
                valid) -> dict:
    """``[data] key = { column = value }`` over mapped columns, each value checked by ``valid``.

    ``valid(value)`` gives the normalised value, or None when the value is refused.
    """
    value = table.get(key, {})
    if not isinstance(value, dict):
        raise where.error(key, "an inline table of column = value", value, f"write {example}")
    out = {}
    for column, item in value.items():
        if column not in columns:
            raise where.problem(
                key, f"column {column!r} is not one of the mapped columns {columns}; name a column of "
                "inputs, outputs, velocities or accelerations"
            )
        checked = valid(item)
        if checked is None:
            raise where.error(key, f"{expected} for {column!r}", item, f"write {example}")
        out[str(column)] = checked
    return out


def _unit_label(unit):
    if not isinstance(unit, str) or not unit.strip() or len(unit) > 20 or not unit.isprintable():
        return None
    return unit.strip()


def _gain(factor):
    if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not math.isfinite(factor) or not factor:
        return None
    return float(factor)


def _units_map(table: Mapping, where: Where, columns: list[str]) -> dict[str, str]:
    """``[data] units = { column = "unit" }``: short unit labels of mapped columns (labels only)."""
    return _column_map(table, where, columns, "units", 'units = { V1 = "V", V2 = "V" }',
                       "a unit label of 1 to 20 printable characters", _unit_label)


def _scale_map(table: Mapping, where: Where, columns: list[str]) -> dict[str, float]:
    """``[data] scale = { column = factor }``: finite, non-zero gains of mapped columns."""
    return _column_map(table, where, columns, "scale", "scale = { current = 35.15 }", "a finite, non-zero number",
                       _gain)


def parse_integrate(table: Mapping, where: Where, fs: float | None, accelerations,
                     velocities) -> IntegrationSpec | None:
    value = table.get("integrate")
    if value is None:
        return None
    key = "integrate"
    example = "integrate = { band_hz = [f_lo, f_hi] }"
    if not isinstance(value, dict):
        raise where.error(key, "an inline table", value, f"write {example}")
    if not accelerations and not velocities:
        raise where.problem(
            key, "integrate derives displacements from accelerations or from velocities (velocity sensors, a laser "
            "vibrometer), but neither is given; add accelerations = { column_name = 1 } or velocities = "
            "{ column_name = 1 }"
        )
    here = Where(where.path, f"{where.section} integrate")
    check_keys(value, _INTEGRATE_KEYS, here)
    band = value.get("band_hz", MISSING)
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
    taper = get_number(value, "taper", here, defaults.taper)
    if not 0 <= taper < 1:
        raise here.error("taper", "a number in [0, 1)", taper)
    return IntegrationSpec(
        band_hz=(float(band[0]), float(band[1])),
        method=get_choice(value, "method", here, INTEGRATION_METHODS, defaults.method),
        taper=taper,
        filter_inputs=get_bool(value, "filter_inputs", here, defaults.filter_inputs),
        filter_order=get_int(value, "filter_order", here, defaults.filter_order, minimum=1),
        detrend_order=get_int(value, "detrend_order", here, defaults.detrend_order, minimum=0),
        noise_std=get_number(value, "noise_std", here, None, positive=True),  # the sensors' noise, declared
        trim_edges=get_bool(value, "trim_edges", here, defaults.trim_edges),
    )


def resolve_file(name: str, where: Where, key: str, check_files: bool) -> Path:
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


def _expand_home(path: Path, where: Where, key: str) -> Path:
    """``~`` and ``~user`` expanded; a user that does not exist is a ConfigError (not RuntimeError)."""
    try:
        return path.expanduser()
    except RuntimeError as exc:
        raise where.problem(key, f"cannot expand {str(path)!r} ({exc}); write the path without '~'") from exc


def _dof_map(table: Mapping, key: str, where: Where, required: bool) -> dict[str, int] | None:
    value = table.get(key, MISSING)
    example = f"{key} = {{ column_name = 1 }}"
    if value is MISSING:
        if required:
            raise where.error(key, "a table mapping column names to DOFs", fix=f"add {example}")
        return None
    if not isinstance(value, dict) or (required and not value):
        raise where.error(key, "a non-empty table mapping column names to DOFs", value, f"write {example}")
    seen: dict[int, str] = {}
    for column, dof in value.items():
        check_name(column, where, f"{key} column {column!r}")
        if not isinstance(dof, int) or isinstance(dof, bool) or dof < 1:
            raise where.error(f"{key}.{column}", "a DOF number >= 1 (DOFs are numbered from 1)", dof)
        if dof in seen:
            raise where.problem(
                key, f"DOF {dof} is mapped twice (columns {seen[dof]!r} and {column!r}); map each DOF to one column"
            )
        seen[dof] = column
    return dict(value)


def _check_columns_unique(where: Where, time_column: str | None, *maps) -> None:
    names = ("inputs", "outputs", "velocities", "accelerations")
    used: dict[str, str] = {time_column: "time_column"} if time_column else {}
    for role, mapping in zip(names, maps):
        for column in mapping or {}:
            if column in used:
                raise where.problem(
                    role, f"column {column!r} is already used as {used[column]}; each column has one role"
                )
            used[column] = role


def parse_nsi(table: Any, where: Where, data: DataSpec) -> NSIOptions:
    """``[nsi]`` as :class:`NSIOptions`, checked against the outputs and the Nyquist frequency of ``data``."""
    if isinstance(table, dict) and "band" in table:
        if "band_hz" in table:
            raise where.problem("band", "band and band_hz are the same setting; keep only band_hz")
        table = {("band_hz" if k == "band" else k): v for k, v in table.items()}
    options = build_options(NSIOptions, table, where)
    if options.order != "auto" and options.order > options.block_rows * len(data.outputs):
        limit = options.block_rows * len(data.outputs)
        raise where.error(
            "order", f"at most block_rows x outputs = {options.block_rows} x {len(data.outputs)} = {limit}",
            options.order, "raise block_rows or lower order",
        )
    if data.realisations > 1 and options.domain != "frequency":
        raise where.problem("domain", f"[data] realisations = {data.realisations} are estimated together on the "
                            'frequency route only (a time-route Hankel block would span two of them); add '
                            'domain = "frequency", or set realisations = 1')
    fs = data.signal_fs
    for key in _BAND_KEYS:
        band = getattr(options, key)
        if band is not None and fs is not None and band[1] > fs / 2:
            raise where.error(key, f"a band below the Nyquist frequency {fs / 2:g} Hz", list(band))
    return options


def parse_candidates(items: Any, path: Path, data: DataSpec) -> tuple[CandidateModel, ...]:
    """``[[candidates]]`` as CandidateModel objects: unique names, terms on measured DOFs, at most
    :data:`MAX_CONFIG_CANDIDATES`."""
    top = Where(path, "[[candidates]]")
    how = 'add at least one [[candidates]] table with name = "..." and terms = [{ expr = "...", at = 1 }]'
    if items is MISSING or items == []:
        raise top.problem(None, f"no candidate models are given; {how}")
    if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
        raise top.error(None, "an array of tables written [[candidates]] (double brackets)", items, how)
    if len(items) > MAX_CONFIG_CANDIDATES:
        raise top.problem(None, f"{len(items)} candidates, more than the {MAX_CONFIG_CANDIDATES} accepted; {TOO_MANY}")
    models, names = [], set()
    for index, item in enumerate(items, start=1):
        where = Where(path, f"[[candidates]] #{index}")
        check_keys(item, _CANDIDATE_KEYS, where)
        name = check_name(get_text(item, "name", where), where, "name")
        where = Where(path, f"[[candidates]] #{index} ({name!r})")
        if name in names:
            raise where.problem("name", f"candidate name {name!r} is used twice; give each candidate its own name")
        names.add(name)
        prior = get_number(item, "prior", where, 1.0, positive=True)
        terms, scales = _parse_terms(item, where, data)
        try:
            models.append(CandidateModel(name=name, terms=terms, prior=prior, coefficient_prior_scales=scales))
        except (ConfigError, ExpressionError) as exc:
            raise where.problem(None, f"{exc}; fix the terms of this candidate") from exc
    return tuple(models)


def _parse_terms(item: Mapping, where: Where, data: DataSpec) -> tuple[tuple[Term, ...], tuple]:
    value = item.get("terms", MISSING)
    if value is MISSING or not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
        raise where.error(
            "terms", 'an array of tables like [{ expr = "v1*abs(v1)", at = 1 }]', value,
            "write terms = [] for a linear model",
        )
    measured = set(data.outputs.values())
    located = set(data.dofs)
    terms, scales = [], []
    for index, entry in enumerate(value, start=1):
        key = f"terms[{index}]"
        here = Where(where.path, f"{where.section} {key}")
        check_keys(entry, _TERM_KEYS, here)
        if "expr" not in entry:
            raise here.error("expr", 'an expression string such as "v1*abs(v1)"', fix='add expr = "..."')
        expr = get_text(entry, "expr", here)
        if "at" not in entry:
            raise here.error("at", "a DOF (at = 1) or a pair of DOFs (at = [1, 2])", fix="add at = <DOF>")
        try:
            term = Term(expr, entry["at"])
        except ExpressionError as exc:
            raise where.problem(f"{key}.expr", f"{exc}") from exc
        unmeasured = sorted(set(term.expr.dofs) - measured)
        if unmeasured:
            sensors = "accelerations" if data.accelerations else "velocities" if data.integrate else "outputs"
            raise where.problem(
                f"{key}.expr", f"{expr!r} reads DOF(s) {unmeasured}, but the responses measure only DOFs "
                f"{sorted(measured)}; use measured DOFs or add a column for each missing DOF to [data] {sensors}"
            )
        outside = sorted(set(term.at) - located)
        if outside:
            raise where.problem(
                f"{key}.at", f"the term acts at DOF(s) {outside}, which are neither forced nor measured "
                f"(known DOFs: {sorted(located)}), so its coefficient cannot be identified (docs/method.md §4); "
                "place it at a measured DOF"
            )
        read = set(term.expr.dofs)
        if read and not read & set(term.at):  # e.g. "(x2-x3)**3" at = 1: legal, but rarely what is meant
            warnings.warn(
                f"{where.path}: {where.section} {key}: {expr!r} reads DOF(s) {sorted(read)} but acts at "
                f"{list(term.at)}; a local element's force acts where it is attached (at = "
                f"{sorted(read)[0] if len(read) == 1 else sorted(read)}). Kept as written",
                BayesNSIWarning, stacklevel=2,
            )
        terms.append(term)
        scales.append(get_number(entry, "prior_scale", here, None, positive=True))
    return tuple(terms), tuple(scales)


def parse_evidence(raw: Mapping, path: Path) -> tuple[EvidenceOptions, int]:
    """``[evidence]`` as :class:`EvidenceOptions` and the run's seed (top-level or ``[evidence] seed``)."""
    where = Where(path, "[evidence]")
    table = raw.get("evidence", {})
    if not isinstance(table, dict):
        raise where.error(None, "a table [evidence]", table)
    top = Where(path, "top level")
    seeds = {}
    if "seed" in raw:
        seeds["top"] = get_int(raw, "seed", top, minimum=0)
    if "seed" in table:
        seeds["evidence"] = get_int(table, "seed", where, minimum=0)
    if len(set(seeds.values())) > 1:
        raise top.problem(
            "seed", f"seed = {seeds['top']} disagrees with [evidence] seed = {seeds['evidence']}; keep one"
        )
    settings = {k: v for k, v in table.items() if k != "seed"}
    seed = next(iter(seeds.values()), 0)
    return build_options(EvidenceOptions, settings, where, seed=seed), seed
