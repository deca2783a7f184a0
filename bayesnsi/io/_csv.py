"""The CSV reader: a header line, an optional units row, then one row per sample.

The file is checked before it is parsed, in bounded memory: the first two lines are read with a
length limit, then the whole file is scanned in chunks for over-long lines and NUL bytes and
its rows are counted, so that the memory the columns need is known (and refused by
:func:`bayesnsi._limits.check_allocation` when too large) before anything is allocated. No
error message quotes the file's content: they name the file, the line and what was expected.
"""

from __future__ import annotations

import csv
import io
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError
from ._columns import MeasurementColumns, sampling_frequency, shown_names

__all__ = ["CSVColumns", "MAX_LINE_BYTES", "read_csv_columns", "read_csv_any"]

MAX_LINE_BYTES = 4 * 2**20
"""Longest accepted line of a measurement CSV, in bytes (4 MiB: some 100 000 columns)."""

_CHUNK_BYTES = 2**20
# bytes per parsed value: the float array, and pandas' copy while converting
_BYTES_PER_VALUE = 16


@dataclass(frozen=True)
class CSVColumns:
    """Some columns of a measurement CSV, as read.

    Parameters
    ----------
    path : Path
        The file.
    names : tuple of str
        Every column named in the header, in file order (trailing empty columns dropped).
    values : dict of str to ndarray, shape (n_samples,)
        The columns that were asked for, as float arrays (NaN where a cell was empty).
    units : dict of str to str
        Units row (empty if the file has none), for every named column.
    first_line : int
        Line number (1-based) of the first sample in the file, for messages.
    """

    path: Path
    names: tuple[str, ...]
    values: dict[str, np.ndarray]
    units: dict[str, str]
    first_line: int

    @property
    def n_samples(self) -> int:
        """Number of data rows."""
        return len(next(iter(self.values.values()))) if self.values else 0

    def locate(self, sample: int) -> str:
        """Where sample ``sample`` is in the file, for messages: ``" (line 12)"``."""
        return f" (line {self.first_line + sample})"


def read_csv_columns(path: str | os.PathLike, columns) -> CSVColumns:
    """Read the named columns of a CSV file (header required, optional units row).

    Parameters
    ----------
    path : str or path-like
        The CSV file; opened read-only.
    columns : iterable of str
        Column names to parse, as in the header (case-sensitive).

    Returns
    -------
    CSVColumns

    Raises
    ------
    InputDataError
        If the file is missing, has no header, repeats a column name, lacks a requested
        column (the message lists the available ones when the header names some of the
        requested columns), has a line longer than :data:`MAX_LINE_BYTES` or a NUL byte,
        would need more memory than ``BAYESNSI_MAX_MEMORY`` allows, or holds a non-numeric
        cell (the message gives column and line).
    """
    path = Path(path)
    header, first_row = _read_head(path)
    wanted = list(dict.fromkeys(columns))
    missing = [c for c in wanted if c not in header]
    if missing and len(missing) == len(wanted):
        raise InputDataError(
            f"{path}, line 1: expected a CSV header naming the column(s) {wanted}, found none of them "
            f"({len([h for h in header if h])} other column name(s)); check [data] file - is it the measurement file?"
        )
    if missing:
        raise InputDataError(
            f"{path}: column(s) {missing} not found; available columns: {shown_names(h for h in header if h)}. "
            "Column names are case-sensitive: fix [data] in the config or the CSV header"
        )
    units = _units(header, first_row)
    skip = 2 if units else 1
    n_lines = _scan_lines(path)
    check_allocation(_BYTES_PER_VALUE * len(wanted) * n_lines, f"{path}: {len(wanted)} column(s) of {n_lines} lines")
    positions = [header.index(c) for c in wanted]
    plain = _read_plain(path, positions, skip)
    if plain is not None:
        values = {c: np.ascontiguousarray(plain[:, k]) for k, c in enumerate(wanted)}
    else:
        frame = _read_frame(path, positions, skip)
        values = {c: _numeric(frame[p], c, path, skip + 1) for c, p in zip(wanted, positions)}
    return CSVColumns(path=path, names=tuple(header), values=values, units=units, first_line=skip + 1)


def read_csv_any(path: Path, columns: list[str], time: str, present: Mapping[str, str]) -> MeasurementColumns:
    """Read ``columns`` of a CSV file (and its time column for fs); ``present`` must exist too."""
    header = _read_head(path)[0]
    use_time = time in header and time not in columns and time not in present
    missing = [c for c in present if c not in header]
    if missing:
        raise InputDataError(
            f"{path}: acceleration column(s) {missing} not found; available columns: {shown_names(header)}"
        )
    table = read_csv_columns(path, list(columns) + ([time] if use_time else []))
    fs = None
    if use_time:
        fs = sampling_frequency(table.values[time], f"{path}: time column {time!r}", table.locate, None)
    values = {c: table.values[c] for c in columns}
    return MeasurementColumns(
        path=path, format="csv", names=table.names, values=values, units=table.units, fs=fs,
        fs_source=f"time column {time!r}" if use_time else "", fs_tolerance=1e-3, first_line=table.first_line,
        hint=f"set fs in [data], or name the time column with [data] time_column (columns: {shown_names(header)})",
    )


def _read_head(path: Path) -> tuple[list[str], list[str]]:
    """Header names (trailing empty ones dropped) and the first data row; lines read with a length limit."""
    if not path.is_file():
        raise InputDataError(f"data file {path} not found; check the name and folder")
    lines = []
    with open(path, "rb") as fh:
        for number in (1, 2):
            line = fh.readline(MAX_LINE_BYTES + 1)
            if len(line) > MAX_LINE_BYTES:
                raise _long_line(path, number)
            _check_text(path, line, number)
            if line:
                lines.append(line.decode("utf-8-sig" if number == 1 else "utf-8"))
    try:
        rows = list(csv.reader(io.StringIO("".join(lines), newline=""), skipinitialspace=True))
    except csv.Error as exc:  # csv messages name the problem (e.g. a field limit), not the content
        raise InputDataError(
            f"{path}: cannot read the header as CSV ({exc}); save it as comma-separated text"
        ) from None
    header = [h.strip() for h in rows[0]] if rows else []
    first_row = rows[1] if len(rows) > 1 else None
    while header and header[-1] == "":
        header.pop()
    if not header:
        raise InputDataError(
            f"{path}, line 1: the first line must be a header naming the columns, found an empty line; "
            "add a header line"
        )
    if all(_is_number(h) for h in header if h):
        raise InputDataError(_headerless(path, len(header)))
    named = [h for h in header if h]
    duplicated = sorted(name for name, count in _counts(named).items() if count > 1)
    if duplicated:
        raise InputDataError(
            f"{path}, line 1: column name(s) {shown_names(duplicated)} appear more than once in the header; rename them"
        )
    if first_row is None:
        raise InputDataError(f"{path}: the file has a header but no data rows")
    return header, first_row


def _headerless(path: Path, n_columns: int) -> InputDataError:
    """The error for a file whose first line holds only numbers: how to give it the header it needs.

    Benchmark data are often shipped as one headerless single-column file per channel (input and
    output apart); the message names ``[data] files``, which reads them as they are.
    """
    return InputDataError(
        f"{path}, line 1: the first line must be a header naming the columns, found only numbers "
        f"({n_columns} column(s), no header); add a header line with the names [data] inputs and outputs use "
        "(e.g. u,y), or, for input and output in separate headerless files (as benchmark data are shipped), "
        'name the file of each column instead of file: [data] files = { u = "u.csv", y = "y.csv" }'
    )


def _counts(names: list[str]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for name in names:
        counts[name] = counts.get(name, 0) + 1
    return counts


def _check_text(path: Path, line: bytes, number: int) -> None:
    if b"\x00" in line:
        raise InputDataError(f"{path}, line {number}: holds a NUL byte; expected comma-separated UTF-8 text")
    try:
        line.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputDataError(
            f"{path}, line {number}: not UTF-8 text (undecodable byte at position {exc.start}); "
            "save it as comma-separated UTF-8"
        ) from None


def _long_line(path: Path, number: int) -> InputDataError:
    return InputDataError(
        f"{path}, line {number}: longer than {MAX_LINE_BYTES} bytes; expected CSV text with one sample per line - "
        "check [data] file"
    )


def _scan_lines(path: Path) -> int:
    """Number of lines, checking in chunks (bounded memory) that none is over-long or holds a NUL byte."""
    done, run = 0, 0  # complete lines so far; bytes of the current line so far
    size = min(_CHUNK_BYTES, MAX_LINE_BYTES)  # so that a line inside one chunk is within the limit
    with open(path, "rb") as fh:
        while chunk := fh.read(size):
            nul = chunk.find(b"\x00")
            if nul >= 0:
                line = done + chunk.count(b"\n", 0, nul) + 1
                raise InputDataError(f"{path}, line {line}: holds a NUL byte; expected comma-separated UTF-8 text")
            first = chunk.find(b"\n")
            if first < 0:
                run += len(chunk)
            else:
                if run + first > MAX_LINE_BYTES:
                    raise _long_line(path, done + 1)
                done += chunk.count(b"\n")
                run = len(chunk) - chunk.rfind(b"\n") - 1  # lines inside a chunk are shorter than the limit
            if run > MAX_LINE_BYTES:
                raise _long_line(path, done + 1)
    return done + (run > 0)


def _units(header: list[str], first_row: list[str]) -> dict[str, str]:
    cells = [c.strip() for c in first_row[: len(header)]]
    if not any(cells) or any(_is_number(c) for c in cells if c):
        return {}
    cells += [""] * (len(header) - len(cells))
    return {name: cell for name, cell in zip(header, cells) if name}


def _read_plain(path: Path, positions: list[int], skip: int) -> np.ndarray | None:
    """The columns of a plain numeric file (every cell a number), by numpy's C reader; None otherwise.

    A third of the time of pandas' reader with its import (0.1 s of a 27 MB file against
    0.07 s + 0.2 s to import pandas). Anything else - an empty or quoted cell, a word, a short
    row, a comment - returns None, and :func:`_read_frame` reads the file as before, with its
    messages.
    """
    try:
        with warnings.catch_warnings():  # a file of no rows is told by _read_frame, not by numpy's warning
            warnings.filterwarnings("ignore", message="loadtxt: input contained no data", category=UserWarning)
            values = np.loadtxt(
                path, delimiter=",", skiprows=skip, usecols=positions, ndmin=2, comments=None, encoding="utf-8",
                dtype=float,
            )
    except (ValueError, UnicodeDecodeError, IndexError):
        return None
    return values if values.shape[0] > 0 else None


def _read_frame(path: Path, positions: list[int], skip: int):
    import pandas as pd  # only for files numpy's reader does not take (empty or non-numeric cells)

    try:
        return pd.read_csv(
            path, header=None, skiprows=skip, usecols=positions, index_col=False, skipinitialspace=True,
            encoding="utf-8-sig",
        )
    except UnicodeDecodeError as exc:
        raise InputDataError(
            f"{path}: not UTF-8 text (undecodable byte at offset {exc.start} of a block); save it as UTF-8"
        ) from None
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputDataError(
            f"{path}: cannot parse the data rows ({_parser_problem(exc)}); the file must be comma-separated "
            "UTF-8 text with one field per header column on every row"
        ) from None


def _parser_problem(exc: Exception) -> str:
    """The pandas message when it only names fields and lines (e.g. 'Expected 3 fields in line 5, saw 4')."""
    text = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
    allowed = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 ,.:()")
    return text if len(text) <= 120 and set(text) <= allowed else type(exc).__name__


def _numeric(series, name: str, path: Path, first_line: int) -> np.ndarray:
    import pandas as pd

    if series.dtype.kind in "fiu":
        return series.to_numpy(dtype=float)
    coerced = pd.to_numeric(series, errors="coerce")
    bad = (coerced.isna() & series.notna()).to_numpy()
    if bad.any():
        row = int(np.argmax(bad))
        raise InputDataError(
            f"{path}: column {name!r}, line {first_line + row} (sample {row}): expected a number, found "
            f"{bad.sum()} non-numeric cell(s) in this column; fix the cell, or remove the row (and keep the time "
            "column uniform)"
        )
    return coerced.to_numpy(dtype=float)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
