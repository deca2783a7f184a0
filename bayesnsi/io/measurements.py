"""Measurements: CSV files -> :class:`~bayesnsi.signals.Signals`, and back (SPEC section 9).

CSV layout: a header line naming the columns; optionally a units row right below it (every
cell non-numeric, e.g. ``"s","N","m"``), then one row per sample. Trailing empty columns (the
Silverbox files end every line with a comma: ``"V1","V2",``) are ignored. Only the columns
named in the config are parsed. Input files are opened read-only and never modified.

Sampling: ``[data] fs`` [Hz], or, when it is absent, a time column (default ``t``, in
seconds) that must be uniformly sampled: fs = (n - 1) / (t[n-1] - t[0]), and every time
stamp must lie within 1 % of a sample interval of that grid.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..exceptions import ConfigError, InputDataError
from ..signals import Signals
from .config import DataSpec, ExperimentConfig
from .results import atomic_open

__all__ = [
    "CSVColumns",
    "read_csv_columns",
    "read_csv_signals",
    "load_signals",
    "load_validation",
    "write_signals_csv",
    "TIME_TOLERANCE",
]

TIME_TOLERANCE = 0.01
"""Largest allowed deviation of a time stamp from the uniform grid, as a fraction of 1/fs."""


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
        If the file is missing or has no header, repeats a column name, lacks a requested
        column (the message lists the available ones) or holds a non-numeric cell (the
        message gives column, line and value).
    """
    path = Path(path)
    header, first_row = _read_head(path)
    wanted = list(dict.fromkeys(columns))
    missing = [c for c in wanted if c not in header]
    if missing:
        raise InputDataError(
            f"{path}: column(s) {missing} not found; available columns: {', '.join(map(repr, header))}. "
            "Column names are case-sensitive: fix [data] in the config or the CSV header"
        )
    units = _units(header, first_row)
    skip = 2 if units else 1
    positions = [header.index(c) for c in wanted]
    frame = _read_frame(path, positions, skip)
    values = {c: _numeric(frame[p], c, path, skip + 1) for c, p in zip(wanted, positions)}
    return CSVColumns(path=path, names=tuple(header), values=values, units=units, first_line=skip + 1)


def read_csv_signals(path: str | os.PathLike, data: DataSpec) -> Signals:
    """Read a whole CSV file into Signals, with the column mapping of ``data``.

    Parameters
    ----------
    path : str or path-like
        The CSV file (``data.file`` is not used, so validation files can share the mapping).
    data : DataSpec
        Column -> DOF maps and sampling. ``estimation`` and ``remove_mean`` are not applied
        here; see :func:`load_signals`.

    Returns
    -------
    Signals
        Forces in the order of ``data.inputs``, displacements in the order of ``data.outputs``,
        velocities (if mapped) in the order of the displacement DOFs.

    Raises
    ------
    InputDataError
        For unreadable files, unknown columns, non-numeric or missing cells, or a time column
        that is not uniformly sampled or disagrees with ``data.fs``.
    """
    record = _Record.read(Path(path), data)
    return record.signals(0, record.n_samples, None)


def load_signals(config: ExperimentConfig) -> Signals:
    """The estimation data of an experiment: the ``[data]`` file, window and mean removal.

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    Signals
        Samples ``estimation[0]:estimation[1]`` (the whole record by default); with
        ``remove_mean`` each channel's mean over that window is subtracted.

    Raises
    ------
    ConfigError
        If the estimation window reaches past the end of the record.
    InputDataError
        As :func:`read_csv_signals`, for the samples inside the window.
    """
    record = _Record.read(config.data.file, config.data)
    start, stop = record.window(config.data.estimation, "[data] estimation", config.path)
    return record.signals(start, stop, record.means(start, stop) if config.data.remove_mean else None)


def load_validation(config: ExperimentConfig) -> list[tuple[str, Signals]]:
    """The validation segments of an experiment, in config order.

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    list of (str, Signals)
        Name and data of each ``[[validation]]`` segment. With ``remove_mean`` the means of the
        *estimation* window are subtracted, so validation data play no part in any choice.

    Raises
    ------
    ConfigError
        If a segment reaches past the end of its record.
    InputDataError
        As :func:`read_csv_signals`.
    """
    if not config.validation:
        return []
    main = _Record.read(config.data.file, config.data)
    means = None
    if config.data.remove_mean:
        means = main.means(*main.window(config.data.estimation, "[data] estimation", config.path))
    out = []
    for segment in config.validation:
        same_file = segment.file is None or segment.file == config.data.file
        record = main if same_file else _Record.read(segment.file, config.data)
        start, stop = record.window(
            (segment.start, segment.stop), f"[[validation]] {segment.name!r} start/stop", config.path
        )
        out.append((segment.name, record.signals(start, stop, means)))
    return out


def write_signals_csv(
    path: str | os.PathLike,
    signals: Signals | None = None,
    *,
    columns: Mapping[str, np.ndarray] | None = None,
    fs: float | None = None,
    units: Mapping[str, str] | None = None,
    float_format: str = "%.12g",
) -> dict:
    """Write signals (and extra columns) to a CSV file atomically, with a time column ``t``.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist. Written to a temporary file, then renamed.
    signals : Signals, optional
        Written as columns ``t``, the input names, the output names and, when measured,
        velocities named ``v<dof>``.
    columns : mapping of str to array_like, shape (n_samples,), optional
        Further columns (e.g. accelerations), or all columns when ``signals`` is None.
    fs : float, optional
        Sampling frequency [Hz]; required without ``signals``, else must match it.
    units : mapping of str to str, optional
        Units written as a second header row (``t`` gets ``"s"``); missing names get ``""``.
    float_format : str
        printf-style format of the numbers.

    Returns
    -------
    dict
        A ``[data]`` table for :func:`bayesnsi.io.dump_config`: ``file`` (the file name, for a
        config in the same folder), ``fs`` and, with ``signals``, ``inputs``, ``outputs`` and
        ``velocities`` maps.
    """
    table: dict[str, np.ndarray] = {}
    maps: dict = {}
    if signals is not None:
        if fs is not None and not math.isclose(fs, signals.fs):
            raise InputDataError(f"fs = {fs} disagrees with signals.fs = {signals.fs}; drop the fs argument")
        fs = signals.fs
        maps = _signal_columns(signals, table)
    if fs is None or not (math.isfinite(fs) and fs > 0):
        raise InputDataError(f"a positive sampling frequency fs [Hz] is needed to write the time column, got {fs!r}")
    for name, values in (columns or {}).items():
        _add_column(table, name, values)
    if not table:
        raise InputDataError("nothing to write: give signals or columns")
    if "t" in table:
        raise InputDataError("column name 't' is reserved for the time column; rename that column")
    n_samples = len(next(iter(table.values())))
    frame = pd.DataFrame({"t": np.arange(n_samples) / fs})
    for name, values in table.items():
        if len(values) != n_samples:
            raise InputDataError(f"column {name!r} has {len(values)} samples, the others {n_samples}")
        frame[name] = values
    with atomic_open(path, "w") as fh:
        if units is not None:
            unit_row = {"t": "s", **dict(units)}
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(list(frame.columns))
            writer.writerow([unit_row.get(name, "") for name in frame.columns])
            frame.to_csv(fh, index=False, header=False, float_format=float_format, lineterminator="\n")
        else:
            frame.to_csv(fh, index=False, float_format=float_format, lineterminator="\n")
    return {"file": Path(path).name, "fs": float(fs), **maps}


# ---------------------------------------------------------------------------------------------
# reading


@dataclass(frozen=True)
class _Record:
    """The mapped columns of one file, before windowing (may hold NaN until checked)."""

    path: Path
    force: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray | None
    fs: float
    data: DataSpec
    first_line: int

    @property
    def n_samples(self) -> int:
        return self.force.shape[0]

    @classmethod
    def read(cls, path: Path, data: DataSpec) -> "_Record":
        header = _read_head(path)[0]
        mapped = list(data.inputs) + list(data.outputs) + list(data.velocities or {})
        time = data.time_column
        use_time = time in header and time not in mapped and time not in data.accelerations
        if data.fs is None and not use_time:
            raise InputDataError(
                f"{path}: no sampling frequency - [data] fs is not set and there is no time column {time!r}; "
                f"set fs in [data], or name the time column with [data] time_column (columns: {', '.join(header)})"
            )
        missing = [c for c in data.accelerations if c not in header]
        if missing:
            raise InputDataError(
                f"{path}: acceleration column(s) {missing} not found; available columns: {', '.join(header)}"
            )
        table = read_csv_columns(path, mapped + ([time] if use_time else []))
        fs = _sampling_frequency(table, time, data.fs) if use_time else data.fs
        velocity = None
        if data.velocities:
            by_dof = {dof: column for column, dof in data.velocities.items()}
            velocity = _stack(table, [by_dof[dof] for dof in data.outputs.values()])
        return cls(
            path=path, force=_stack(table, data.inputs), displacement=_stack(table, data.outputs),
            velocity=velocity, fs=fs, data=data, first_line=table.first_line,
        )

    def window(self, bounds, key: str, config_path: Path) -> tuple[int, int]:
        start, stop = bounds if bounds is not None else (None, None)
        start = 0 if start is None else start
        stop = self.n_samples if stop is None else stop
        if stop > self.n_samples or start >= stop:
            raise ConfigError(
                f"{config_path}: {key}: expected a window inside the record of {self.n_samples} samples "
                f"in {self.path.name}, found [{start}, {stop}); shrink the window"
            )
        return start, stop

    def means(self, start: int, stop: int) -> dict[str, np.ndarray]:
        self._check_finite(start, stop)
        parts = {"force": self.force, "displacement": self.displacement, "velocity": self.velocity}
        return {k: v[start:stop].mean(axis=0) for k, v in parts.items() if v is not None}

    def signals(self, start: int, stop: int, means: dict | None) -> Signals:
        self._check_finite(start, stop)
        parts = {"force": self.force, "displacement": self.displacement, "velocity": self.velocity}
        cut = {k: (None if v is None else v[start:stop] - (means[k] if means else 0.0)) for k, v in parts.items()}
        return Signals(
            force=cut["force"], displacement=cut["displacement"], velocity=cut["velocity"], fs=self.fs,
            input_dofs=tuple(self.data.inputs.values()), output_dofs=tuple(self.data.outputs.values()),
            input_names=tuple(self.data.inputs), output_names=tuple(self.data.outputs),
        )

    def _check_finite(self, start: int, stop: int) -> None:
        groups = [(self.data.inputs, self.force), (self.data.outputs, self.displacement)]
        if self.velocity is not None:
            by_dof = {dof: column for column, dof in self.data.velocities.items()}
            groups.append(({by_dof[d]: d for d in self.data.outputs.values()}, self.velocity))
        for names, values in groups:
            bad = ~np.isfinite(values[start:stop])
            if bad.any():
                row, col = np.argwhere(bad)[0]
                raise InputDataError(
                    f"{self.path}: column {list(names)[col]!r} has {int(bad.sum())} missing or non-finite value(s) "
                    f"in samples [{start}, {stop}), the first at sample {start + row} (line "
                    f"{self.first_line + start + row}); fill or remove them, or choose a window that excludes them"
                )


def _read_head(path: Path) -> tuple[list[str], list[str] | None]:
    """Header names (trailing empty ones dropped) and the first data row, via the csv module."""
    if not path.is_file():
        raise InputDataError(f"data file {path} not found; check the name and folder")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh, skipinitialspace=True)
            header = [h.strip() for h in next(reader, [])]
            first_row = next(reader, None)
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputDataError(f"{path}: cannot read it as UTF-8 CSV text ({exc}); save it as comma-separated UTF-8") from exc
    while header and header[-1] == "":
        header.pop()
    if not header or all(_is_number(h) for h in header if h):
        raise InputDataError(
            f"{path}: the first line must be a header naming the columns, found {header[:6]}; add a header line"
        )
    named = [h for h in header if h]
    duplicated = sorted({h for h in named if named.count(h) > 1})
    if duplicated:
        raise InputDataError(f"{path}: column name(s) {duplicated} appear more than once in the header; rename them")
    if first_row is None:
        raise InputDataError(f"{path}: the file has a header but no data rows")
    return header, first_row


def _units(header: list[str], first_row: list[str]) -> dict[str, str]:
    cells = [c.strip() for c in first_row[: len(header)]]
    if not any(cells) or any(_is_number(c) for c in cells if c):
        return {}
    cells += [""] * (len(header) - len(cells))
    return {name: cell for name, cell in zip(header, cells) if name}


def _read_frame(path: Path, positions: list[int], skip: int) -> pd.DataFrame:
    try:
        return pd.read_csv(
            path, header=None, skiprows=skip, usecols=positions, index_col=False, skipinitialspace=True,
            encoding="utf-8-sig",
        )
    except (ValueError, pd.errors.ParserError) as exc:  # UnicodeDecodeError is a ValueError
        raise InputDataError(
            f"{path}: cannot parse the data rows ({exc}); the file must be comma-separated UTF-8 text "
            "with one field per header column on every row"
        ) from exc


def _numeric(series: pd.Series, name: str, path: Path, first_line: int) -> np.ndarray:
    if series.dtype.kind in "fiu":
        return series.to_numpy(dtype=float)
    coerced = pd.to_numeric(series, errors="coerce")
    bad = (coerced.isna() & series.notna()).to_numpy()
    if bad.any():
        row = int(np.argmax(bad))
        raise InputDataError(
            f"{path}: column {name!r}, line {first_line + row} (sample {row}): {series.iloc[row]!r} is not a number; "
            "fix the cell, or remove the row (and keep the time column uniform)"
        )
    return coerced.to_numpy(dtype=float)


def _sampling_frequency(table: CSVColumns, time: str, fs: float | None) -> float:
    t = table.values[time]
    where = f"{table.path}: time column {time!r}"
    if not np.all(np.isfinite(t)):
        row = int(np.argmax(~np.isfinite(t)))
        raise InputDataError(f"{where} has a missing value at line {table.first_line + row}; fill it or set [data] fs")
    if len(t) < 2:
        raise InputDataError(f"{where}: need at least two samples to derive fs")
    dt = (t[-1] - t[0]) / (len(t) - 1)
    deviation = np.abs(t - (t[0] + dt * np.arange(len(t))))
    if not dt > 0 or np.any(np.diff(t) <= 0) or deviation.max() > TIME_TOLERANCE * dt:
        row = int(np.argmax(deviation)) if dt > 0 else 0
        raise InputDataError(
            f"{where} is not uniformly sampled: expected increasing time stamps within {TIME_TOLERANCE:g} of a "
            f"sample interval ({dt:.6g} s) of a uniform grid, found a deviation of {deviation.max():.3g} s at line "
            f"{table.first_line + row}; resample the record to a uniform rate"
        )
    derived = 1.0 / dt
    if fs is not None and abs(derived - fs) > 1e-3 * fs:
        raise InputDataError(
            f"{where} gives fs = {derived:.9g} Hz but [data] fs = {fs:g} Hz; correct fs, or drop it to use the time column"
        )
    return fs if fs is not None else derived


def _stack(table: CSVColumns, columns) -> np.ndarray:
    return np.column_stack([table.values[c] for c in columns])


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------------------------------
# writing


def _signal_columns(signals: Signals, table: dict) -> dict:
    section = {
        "inputs": dict(zip(signals.input_names, signals.input_dofs)),
        "outputs": dict(zip(signals.output_names, signals.output_dofs)),
    }
    for i, name in enumerate(signals.input_names):
        _add_column(table, name, signals.force[:, i])
    for i, name in enumerate(signals.output_names):
        _add_column(table, name, signals.displacement[:, i])
    if signals.velocity is not None:
        names = [f"v{dof}" for dof in signals.output_dofs]
        if set(names) & set(table):
            names = [f"{name}_velocity" for name in signals.output_names]
        for i, name in enumerate(names):
            _add_column(table, name, signals.velocity[:, i])
        section["velocities"] = dict(zip(names, signals.output_dofs))
    return section


def _add_column(table: dict, name: str, values) -> None:
    if not isinstance(name, str) or not name.strip() or name in table:
        raise InputDataError(f"column name {name!r} is empty or used twice; give each column its own name")
    array = np.asarray(values, dtype=float)
    if array.ndim != 1:
        raise InputDataError(f"column {name!r} must be one-dimensional, got shape {array.shape}")
    table[name] = array
