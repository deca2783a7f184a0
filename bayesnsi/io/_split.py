"""Channels each in a file of its own (``[data] files``), as benchmark data are often shipped.

The nonlinear system identification benchmarks (nonlinearbenchmark.org: Bouc-Wen, Silverbox,
cascaded tanks, ...) ship input and output as separate files, e.g. ``uval_multisine.csv`` and
``yval_multisine.csv``, each one headerless column of numbers. ``[data] files = { u = "u.csv",
y = "y.csv" }`` names the file of every mapped column, and :func:`read_split` reads them into one
:class:`~bayesnsi.io._columns.MeasurementColumns`, as if they were the columns of one file.

Each file is read by its format (:func:`bayesnsi.io._columns.file_format`):

* CSV whose first line holds only numbers (headerless): it must hold one column, the channel.
  The file is scanned as any CSV is (line length, NUL bytes, memory limit) before it is parsed;
  every cell must be a finite number (an empty, non-numeric or non-finite cell is an error naming
  the file and line: with one channel per file there is no window to exclude it by).
* CSV with a header: the column of the channel's name; its values must be finite too.
* MAT, HDF5, UFF: the variable or record of the channel's name, as for ``[data] file``; a MAT
  (v4-v7) file without that variable but with a single vector gives that vector (a benchmark's
  ``uval_multisine.mat`` holds one variable, ``uval_multisine``).

All files must hold the same number of samples. They carry no time column: ``[data] fs`` is
required with ``files`` (checked when the config is read).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError
from ._columns import MeasurementColumns, file_format

__all__ = ["read_split"]

_BYTES_PER_VALUE = 16  # the float array and a parser's copy


def read_split(files: Mapping[str, Path], roles: Mapping[str, str], time_column: str,
               read_other: Callable[..., MeasurementColumns]) -> MeasurementColumns:
    """Read each channel of ``files`` from its own file (module notes).

    Parameters
    ----------
    files : mapping of str to Path
        Channel (column) name -> its file, absolute.
    roles : mapping of str to str
        Channel -> role ("input", "displacement", "velocity", "acceleration"), for the readers of
        formats that check roles (UFF).
    time_column : str
        Name of a time column/vector, passed to the readers of headed files (not used for fs).
    read_other : callable
        ``read_other(path, columns, roles, time_column, present)`` reads a MAT, HDF5 or UFF file
        (:func:`bayesnsi.io._record.read_any`, passed in so that this module imports no reader of
        the record).

    Returns
    -------
    MeasurementColumns
        The channels under their config names; ``path`` is the first file, ``fs`` None (``[data]
        fs`` gives the rate), no units (``[data] units`` labels the axes).

    Raises
    ------
    InputDataError
        If a file is missing, unreadable, holds more than one column without a header, lacks the
        channel, holds a non-numeric or non-finite value, or the files differ in length.
    """
    if not files:
        raise InputDataError("no channel files given ([data] files is empty)")
    values = {column: _channel(Path(path), column, roles.get(column, "input"), time_column, read_other)
              for column, path in files.items()}
    first = Path(next(iter(files.values())))
    lengths = {column: len(v) for column, v in values.items()}
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"{column!r} ({Path(files[column]).name}): {n}" for column, n in lengths.items())
        raise InputDataError(
            f"the files of [data] files hold different numbers of samples ({shown}); every channel must be "
            "sampled together - give files of the same record"
        )
    return MeasurementColumns(
        path=first, format="split", names=tuple(files), values=values, units={}, fs=None,
        hint="set fs in [data] (files of single channels carry no time column)",
    )


def _channel(path: Path, column: str, role: str, time_column: str, read_other) -> np.ndarray:
    """The one channel ``column`` of ``path``."""
    from ._csv import _is_number, _read_head, _scan_lines

    if not path.is_file():
        raise InputDataError(f"data file {path} (channel {column!r}) not found; check the name and folder")
    if file_format(path) != "csv":
        name = _only_vector(path, column, time_column) or column
        return read_other(path, [name], {name: role}, time_column, {}).values[name]
    try:
        header = _read_head(path)[0]
    except InputDataError:  # a headerless file (or an empty one: reported below)
        header = None
    if header is not None and not all(_is_number(h) for h in header if h):
        from ._csv import read_csv_columns

        named = [h for h in header if h]
        if column not in named:  # the header is not quoted: the file may be anything (a system file)
            raise InputDataError(
                f"{path}, line 1: a header without the column {column!r} ({len(named)} column name(s)); name "
                "the channel's column as in the config, or give a headerless file of that one channel"
            )
        table = read_csv_columns(path, [column])
        values = table.values[column]
        if not np.all(np.isfinite(values)):
            row = int(np.argmax(~np.isfinite(values)))
            raise InputDataError(
                f"{path}{table.locate(row)}: channel {column!r} expected a finite number (a missing or non-finite "
                "value); fix or remove the line"
            )
        return values
    n_lines = _scan_lines(path)
    check_allocation(_BYTES_PER_VALUE * n_lines, f"{path}: 1 column of {n_lines} lines")
    return _headerless_column(path, column, n_lines)


def _only_vector(path: Path, column: str, time_column: str) -> str | None:
    """The one vector variable of a MAT (v4-v7) file that has no variable ``column``, else None.

    A benchmark's ``uval_multisine.mat`` holds one variable named after the file; ``files = { u =
    "uval_multisine.mat" }`` reads it as channel ``u`` (the time vector and ``fs`` do not count).
    Anything else - HDF5 / v7.3, an unreadable file, several vectors - is left to the reader's
    own message.
    """
    if file_format(path) != "mat":
        return None
    import scipy.io

    try:
        info = scipy.io.whosmat(str(path))
    except Exception:  # noqa: BLE001 - not a v4-v7 MAT file: the reader says what is wrong
        return None
    if any(name == column for name, _, _ in info):
        return None
    vectors = [name for name, shape, _ in info
               if name not in (time_column, "fs") and len(shape) == 2 and min(shape) == 1 and max(shape) > 1]
    return vectors[0] if len(vectors) == 1 else None


def _headerless_column(path: Path, column: str, n_lines: int) -> np.ndarray:
    """Every line of ``path`` as one number (blank lines at the end allowed); errors name the line.

    numpy's C reader takes a plain file of ``n_lines`` numbers; anything else (a second cell, a
    word, an empty or non-finite cell, a blank line, which that reader would skip and so shift
    every later sample) is read again line by line for a message that names the line.
    """
    try:
        plain = np.loadtxt(path, delimiter=",", ndmin=2, comments=None, encoding="utf-8-sig", dtype=float)
    except (ValueError, UnicodeDecodeError):
        plain = None
    if plain is not None and plain.shape == (n_lines, 1) and n_lines > 0 and np.all(np.isfinite(plain)):
        return np.ascontiguousarray(plain[:, 0])
    try:
        values = _lines(path, column)
    except UnicodeDecodeError as exc:
        raise InputDataError(f"{path}: not UTF-8 text (undecodable byte at offset {exc.start} of a line); "
                             "save it as UTF-8") from None
    while values and values[-1] is None:
        values.pop()
    if not values:
        raise InputDataError(f"{path}: channel {column!r} holds no samples")
    if None in values:
        raise InputDataError(
            f"{path}, line {values.index(None) + 1}: empty line inside channel {column!r}; remove it"
        )
    return np.asarray(values, dtype=float)


def _lines(path: Path, column: str) -> list[float | None]:
    """One number per line (None for a blank line); a line with several cells or a bad number is an error."""
    values: list[float | None] = []
    with open(path, encoding="utf-8-sig") as fh:
        for number, line in enumerate(fh, start=1):
            cells = [c.strip() for c in line.strip().split(",")]
            while len(cells) > 1 and cells[-1] == "":  # a trailing comma, as some exports write
                cells.pop()
            if cells == [""]:
                values.append(None)
                continue
            if len(cells) != 1:
                raise InputDataError(
                    f"{path}, line {number}: {len(cells)} cells; a headerless file of [data] files holds one "
                    f"channel ({column!r}), one number per line - split the columns into files, or add a header "
                    "and use [data] file"
                )
            try:
                value = float(cells[0])
            except ValueError:
                value = float("nan")
            if not np.isfinite(value):
                raise InputDataError(
                    f"{path}, line {number}: channel {column!r} expected a finite number; fix or remove the line"
                )
            values.append(value)
    return values
