"""The ``[[validation]]`` segments of an experiment config: held-out records, each checked and typed."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from ._config_fields import MISSING, Where, check_keys, check_name, get_int, get_text
from ._config_files import check_files_cover, parse_files
from ._config_sections import parse_integrate, resolve_file
from ._specs import DataSpec, ValidationSegment

__all__ = ["parse_validation"]

_VALIDATION_KEYS = tuple(f.name for f in dataclasses.fields(ValidationSegment))


def parse_validation(items: Any, path: Path, data: DataSpec, check_files: bool) -> tuple[ValidationSegment, ...]:
    """``[[validation]]`` segments, none overlapping the estimation window of the data file."""
    top = Where(path, "[[validation]]")
    if not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
        raise top.error(None, "an array of tables written [[validation]] (double brackets)", items)
    segments, names = [], set()
    for index, item in enumerate(items, start=1):
        where = Where(path, f"[[validation]] #{index}")
        check_keys(item, _VALIDATION_KEYS, where)
        name = check_name(get_text(item, "name", where), where, "name")
        if name in names:
            raise where.problem("name", f"validation name {name!r} is used twice; give each segment its own name")
        names.add(name)
        files = parse_files(item, where, lambda text, key: resolve_file(text, where, key, check_files))  # noqa: B023 - called at once
        if files:  # another record, one file per channel: the columns of [data]
            check_files_cover(files, [*data.inputs, *(data.outputs if data.integrate is None else {}),
                                      *(data.velocities or {}), *data.accelerations], where)
        file = resolve_file(get_text(item, "file", where), where, "file", check_files) if "file" in item else None
        start = get_int(item, "start", where, None if file or files else MISSING, minimum=0)
        stop = get_int(item, "stop", where, None if file or files else MISSING, minimum=1)
        if start is not None and stop is not None and start >= stop:
            raise where.error("stop", f"an index greater than start = {start}", stop)
        if not files and (file is None or file == data.file):
            _check_no_overlap(where, name, start, stop, data.estimation)
        count, drop = get_int(item, "realisations", where, 1, minimum=1), get_int(item, "transient_periods", where, 0,
                                                                                    minimum=0)
        period = get_int(item, "period", where, None, minimum=0)
        if period == 1 or (period and period % data.decimate):
            raise where.error("period", f"0 (not periodic) or a multiple of decimate ({data.decimate}) samples >= 2",
                              period)
        if (data.period is None if period is None else period == 0) and (count > 1 or drop):
            raise where.problem("realisations", "needs the period of the test: add [data] period (or period here)")
        integrate = None
        if "integrate" in item:
            if data.integrate is None:
                raise where.problem("integrate", "needs [data] integrate (the sensors this segment integrates)")
            integrate = parse_integrate(item, where, data.fs, data.accelerations, data.velocities)
        segments.append(ValidationSegment(name=name, start=start, stop=stop, file=file, files=files,
                                          realisations=count, transient_periods=drop, period=period,
                                          integrate=integrate))
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
