"""Measurements: files -> :class:`~bayesnsi.signals.Signals`, and Signals -> CSV (SPEC section 9).

The format follows the extension of the file (:data:`FORMATS`): ``.mat`` (MATLAB; v4/v5/v7 via
:func:`scipy.io.loadmat`, v7.3 = HDF5 via h5py), ``.h5``/``.hdf5`` (HDF5 via h5py),
``.uff``/``.unv`` (Universal File Format dataset 58 via pyuff); any other extension is read
as CSV text. Input files are opened read-only and never modified. Only the channels named
in the config are converted. Channels of one response kind (displacements, velocities,
accelerations) must share a unit where the file states units (CSV units row, UFF ordinate
units label); units are reported, never converted.

**CSV**: a header line naming the columns; optionally a units row right below it (every
cell non-numeric, e.g. ``"s","N","m"``), then one row per sample. Trailing empty columns (the
Silverbox files end every line with a comma: ``"V1","V2",``) are ignored.

**MAT / HDF5**: one variable per channel, named like a CSV column (case-sensitive); each a
real numeric vector, 1×N or N×1 (MATLAB classes double, single and the integer types; a
struct, cell, char, logical, complex or sparse variable is an error). In HDF5 files a name may
be a path (``"group/x1"``). Optional sampling information in the file: a time vector named
``[data] time_column`` (default ``t``) and/or a scalar ``fs`` [Hz]. Other variables (e.g. the
Silverbox overload flags ``Ovld1``) are ignored.

**UFF58**: one time record (function type 1, or 0 "general"; real values; time abscissa)
per channel. A config key names a record by its ``id1`` text (the first ID line, surrounding
blanks ignored), or, when no record has that id1, by ``"node:dir"``: response node and
direction, the direction as X, Y, Z, RX, RY, RZ with an optional sign (``"2:+Z"``, ``"2:Z"``,
``"7:-X"``) or as the numeric UFF code (``"2:3"``). Keys that match several records are an
error. Sampling interval from ``abscissa_inc`` (even spacing) or from the abscissa values
(uneven spacing, checked to be uniform); all records must share interval, start time and
length. A record whose specific data type contradicts its role (e.g. an acceleration record
mapped as a displacement output) is an error; inputs are not checked (a base acceleration
may be the input). The ordinate units label is reported in :attr:`MeasurementColumns.units`.
Note that pyuff writes ``abscissa_inc`` with 6 significant digits (E13.5) and ASCII data
with 12, so give ``[data] fs`` for an exact rate and prefer binary UFF58 for full precision.

**Sampling**: ``[data] fs`` [Hz], or, when it is absent, the file's: a time column/vector
(default ``t``, in seconds) that must be uniformly sampled - fs = (n - 1) / (t[n-1] - t[0]),
every time stamp within 1 % of a sample interval of that grid -, a scalar ``fs`` variable,
or the UFF sampling interval. When both are given they must agree: within 1e-3 (relative)
for a rate derived from time stamps, within :data:`FS_TOLERANCE` for a stored number (a
scalar ``fs`` or ``abscissa_inc``); ``[data] fs`` is then used.

**Processing** (:func:`load_signals`, :func:`load_validation`, :func:`read_signals`): each
window is cut from the file, then integrated when ``[data] integrate`` is given
(:func:`bayesnsi.preprocess.integrate_acceleration`; the forces are filtered with the same
band unless ``filter_inputs = false``), then decimated when ``[data] decimate > 1``
(:func:`bayesnsi.preprocess.decimate`), then mean-removed when ``remove_mean``. See
:class:`~bayesnsi.io.config.DataSpec`.
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

from .. import preprocess
from ..exceptions import ConfigError, InputDataError
from ..signals import Signals
from .config import DataSpec, ExperimentConfig
from .results import atomic_open

__all__ = [
    "CSVColumns",
    "MeasurementColumns",
    "read_csv_columns",
    "read_columns",
    "read_signals",
    "read_csv_signals",
    "load_signals",
    "load_validation",
    "write_signals_csv",
    "file_format",
    "FORMATS",
    "FS_TOLERANCE",
    "TIME_TOLERANCE",
]

TIME_TOLERANCE = 0.01
"""Largest allowed deviation of a time stamp from the uniform grid, as a fraction of 1/fs."""

FS_TOLERANCE = 1e-4
"""Largest relative difference between ``[data] fs`` and a rate stored in the file as a number
(a scalar ``fs`` variable, UFF ``abscissa_inc``, which pyuff writes with 6 significant digits)."""

FORMATS = {".mat": "mat", ".h5": "hdf5", ".hdf5": "hdf5", ".uff": "uff", ".unv": "uff"}
"""File extension (lower case) -> format; every other extension is read as CSV text."""


def file_format(path: str | os.PathLike) -> str:
    """The format a file is read as: "csv", "mat", "hdf5" or "uff" (from its extension)."""
    return FORMATS.get(Path(path).suffix.lower(), "csv")


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


@dataclass(frozen=True)
class MeasurementColumns:
    """Some channels of a measurement file of any supported format, as read.

    Parameters
    ----------
    path : Path
        The file.
    format : {"csv", "mat", "hdf5", "uff"}
    names : tuple of str
        Every channel the file offers: CSV header names, MAT/HDF5 variable names, or UFF58
        records as ``"'id1' (node:dir)"``.
    values : dict of str to ndarray, shape (n_samples,)
        The channels asked for, as float arrays, under the names used to ask for them.
    units : dict of str to str
        Units stated in the file (CSV units row, UFF ordinate units label); may be empty.
    fs : float or None
        Sampling frequency stored in the file [Hz] (time column/vector, scalar ``fs``,
        UFF ``abscissa_inc``); None when the file has none.
    fs_source : str
        Where ``fs`` came from, for messages.
    fs_tolerance : float
        Relative tolerance when ``fs`` is compared with ``[data] fs``.
    first_line : int or None
        CSV only: line number (1-based) of the first sample.
    hint : str
        What to do when the file has no sampling information.
    """

    path: Path
    format: str
    names: tuple[str, ...]
    values: dict[str, np.ndarray]
    units: dict[str, str]
    fs: float | None
    fs_source: str = ""
    fs_tolerance: float = FS_TOLERANCE
    first_line: int | None = None
    hint: str = "set fs in [data]"

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return len(next(iter(self.values.values()))) if self.values else 0

    def locate(self, sample: int) -> str:
        """Where sample ``sample`` is in the file, for messages (a CSV line number, else empty)."""
        return f" (line {self.first_line + sample})" if self.first_line is not None else ""


def read_columns(path: str | os.PathLike, columns, time_column: str = "t") -> MeasurementColumns:
    """Read named channels of a measurement file of any supported format (see :data:`FORMATS`).

    Parameters
    ----------
    path : str or path-like
        The file; the format follows its extension.
    columns : iterable of str
        CSV column names, MAT/HDF5 variable names, or UFF58 record keys (id1 text or
        ``"node:dir"``).
    time_column : str
        Name of a time column/variable [s] used, when present and not asked for, to give
        :attr:`MeasurementColumns.fs`.

    Returns
    -------
    MeasurementColumns

    Raises
    ------
    InputDataError
        For a missing or unreadable file, missing channels (the message lists the available
        ones), channels that are not real numeric vectors, channels of different lengths,
        sampling intervals or start times, or non-uniform time stamps.
    """
    wanted = list(dict.fromkeys(columns))
    return _read_any(Path(path), wanted, {}, time_column, {})


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


def read_signals(path: str | os.PathLike, data: DataSpec) -> Signals:
    """Read a whole measurement file (any supported format) into Signals, mapped by ``data``.

    Parameters
    ----------
    path : str or path-like
        The file (``data.file`` is not used, so validation files can share the mapping); the
        format follows its extension (:data:`FORMATS`).
    data : DataSpec
        Column -> DOF maps and sampling; ``integrate`` and ``decimate`` are applied to the
        whole record. ``estimation`` and ``remove_mean`` are not applied here; see
        :func:`load_signals`.

    Returns
    -------
    Signals
        Forces in the order of ``data.inputs``, displacements in the order of ``data.outputs``,
        velocities (if mapped, or integrated) in the order of the displacement DOFs.

    Raises
    ------
    InputDataError
        For unreadable files, unknown channels, non-numeric or missing values, channels of
        different lengths or sampling intervals, or a sampling rate in the file that
        disagrees with ``data.fs``.
    """
    record = _Record.read(Path(path), data)
    return record.signals(0, record.n_samples, None)


read_csv_signals = read_signals
"""Alias of :func:`read_signals` (its former name, when only CSV was read)."""


def load_signals(config: ExperimentConfig) -> Signals:
    """The estimation data of an experiment: the ``[data]`` file, window and mean removal.

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    Signals
        Samples ``estimation[0]:estimation[1]`` of the file (the whole record by default),
        integrated and decimated as ``[data]`` asks; with ``remove_mean`` each channel's mean
        over that window is subtracted.

    Raises
    ------
    ConfigError
        If the estimation window reaches past the end of the record.
    InputDataError
        As :func:`read_signals`, for the samples inside the window.
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
        As :func:`read_signals`.
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


class _Record:
    """The mapped channels of one file (raw, may hold NaN until a window is checked), and the
    processing of a window into Signals: cut -> integrate -> decimate -> remove means."""

    def __init__(self, path: Path, data: DataSpec):
        self.path = Path(path)
        self.data = data
        self.integrate = data.integrate
        if self.integrate is not None:
            responses = {c: "acceleration" for c in data.accelerations}
        else:
            responses = {c: "displacement" for c in data.outputs}
            responses.update({c: "velocity" for c in data.velocities or {}})
        roles = {c: "input" for c in data.inputs} | responses
        present = {} if self.integrate is not None else {c: "acceleration" for c in data.accelerations}
        table = _read_any(self.path, list(roles), roles, data.time_column, present)
        self.table = table
        self.fs = _resolve_fs(table, data)
        _check_units(table, roles)
        self.force = _stack(table, data.inputs)
        self.velocity = None
        self.acceleration = None
        self.displacement = None
        if self.integrate is not None:
            self.acceleration = _stack(table, data.accelerations)
        else:
            self.displacement = _stack(table, data.outputs)
            if data.velocities:
                by_dof = {dof: column for column, dof in data.velocities.items()}
                self.velocity = _stack(table, [by_dof[dof] for dof in data.outputs.values()])
        self._cache: dict[tuple[int, int], dict[str, np.ndarray | None]] = {}

    @classmethod
    def read(cls, path: Path, data: DataSpec) -> "_Record":
        return cls(path, data)

    @property
    def n_samples(self) -> int:
        return self.force.shape[0]

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
        parts = self._processed(start, stop)
        return {k: v.mean(axis=0) for k, v in parts.items() if v is not None}

    def signals(self, start: int, stop: int, means: dict | None) -> Signals:
        parts = self._processed(start, stop)
        cut = {k: (None if v is None else v - (means[k] if means else 0.0)) for k, v in parts.items()}
        return Signals(
            force=cut["force"], displacement=cut["displacement"], velocity=cut["velocity"],
            fs=self.fs / self.data.decimate,
            input_dofs=tuple(self.data.inputs.values()), output_dofs=tuple(self.data.outputs.values()),
            input_names=tuple(self.data.inputs), output_names=tuple(self.data.outputs),
        )

    def _processed(self, start: int, stop: int) -> dict[str, np.ndarray | None]:
        """Window [start, stop) of the file, integrated and decimated as [data] asks (cached)."""
        key = (start, stop)
        if key in self._cache:
            return self._cache[key]
        self._check_finite(start, stop)
        force = self.force[start:stop]
        spec = self.integrate
        try:
            if spec is not None:
                options = {"taper": spec.taper, "filter_order": spec.filter_order}
                velocity, displacement = preprocess.integrate_acceleration(
                    self.acceleration[start:stop], self.fs, spec.band_hz, spec.method,
                    detrend_order=spec.detrend_order, **options,
                )
                if spec.filter_inputs:
                    force = preprocess.band_filter(force, self.fs, spec.band_hz, spec.method, **options)
            else:
                displacement = self.displacement[start:stop]
                velocity = None if self.velocity is None else self.velocity[start:stop]
            parts = {"force": force, "displacement": displacement, "velocity": velocity}
            if self.data.decimate > 1:
                parts = {k: None if v is None else preprocess.decimate(v, self.data.decimate) for k, v in parts.items()}
        except InputDataError as exc:
            raise InputDataError(f"{self.path}: samples [{start}, {stop}): {exc}") from exc
        self._cache[key] = parts
        return parts

    def _check_finite(self, start: int, stop: int) -> None:
        groups = [(self.data.inputs, self.force)]
        if self.integrate is not None:
            groups.append((self.data.accelerations, self.acceleration))
        else:
            groups.append((self.data.outputs, self.displacement))
            if self.velocity is not None:
                by_dof = {dof: column for column, dof in self.data.velocities.items()}
                groups.append(({by_dof[d]: d for d in self.data.outputs.values()}, self.velocity))
        for names, values in groups:
            bad = ~np.isfinite(values[start:stop])
            if bad.any():
                row, col = np.argwhere(bad)[0]
                raise InputDataError(
                    f"{self.path}: column {list(names)[col]!r} has {int(bad.sum())} missing or non-finite value(s) "
                    f"in samples [{start}, {stop}), the first at sample {start + row}"
                    f"{self.table.locate(start + row)}; fill or remove them, or choose a window that excludes them"
                )


def _read_any(path: Path, columns: list[str], roles: Mapping[str, str], time_column: str,
              present: Mapping[str, str]) -> MeasurementColumns:
    """Read ``columns`` of any supported file; check that the ``present`` ones exist."""
    kind = file_format(path)
    if not path.is_file():
        raise InputDataError(f"data file {path} not found; check the name and folder")
    if kind == "csv":
        return _read_csv_any(path, columns, time_column, present)
    from ._formats import read_matlike, read_uff  # binary formats; they reuse this module's helpers

    if kind == "uff":
        return read_uff(path, columns, roles, present)
    return read_matlike(path, columns, time_column, present)


def _read_csv_any(path: Path, columns: list[str], time: str, present: Mapping[str, str]) -> MeasurementColumns:
    header = _read_head(path)[0]
    use_time = time in header and time not in columns and time not in present
    missing = [c for c in present if c not in header]
    if missing:
        raise InputDataError(
            f"{path}: acceleration column(s) {missing} not found; available columns: {', '.join(header)}"
        )
    table = read_csv_columns(path, list(columns) + ([time] if use_time else []))
    fs = None
    if use_time:
        fs = _sampling_frequency(table.values[time], f"{path}: time column {time!r}", table.locate, None)
    values = {c: table.values[c] for c in columns}
    return MeasurementColumns(
        path=path, format="csv", names=table.names, values=values, units=table.units, fs=fs,
        fs_source=f"time column {time!r}" if use_time else "", fs_tolerance=1e-3, first_line=table.first_line,
        hint=f"set fs in [data], or name the time column with [data] time_column (columns: {', '.join(header)})",
    )


def _resolve_fs(table: MeasurementColumns, data: DataSpec) -> float:
    if table.fs is None:
        if data.fs is None:
            raise InputDataError(f"{table.path}: no sampling frequency - [data] fs is not set and {table.hint}")
        return data.fs
    if data.fs is not None and abs(table.fs - data.fs) > table.fs_tolerance * data.fs:
        fix = "correct fs, or drop it to use the " + ("time column" if table.format == "csv" else table.fs_source)
        raise InputDataError(
            f"{table.path}: {table.fs_source} gives fs = {table.fs:.9g} Hz but [data] fs = {data.fs:g} Hz; {fix}"
        )
    return data.fs if data.fs is not None else table.fs


def _check_units(table: MeasurementColumns, roles: Mapping[str, str]) -> None:
    """Channels of one response kind must share a unit where the file states units."""
    by_role: dict[str, dict[str, str]] = {}
    for name, role in roles.items():
        unit = table.units.get(name, "").strip()
        if unit and role != "input":
            by_role.setdefault(role, {})[name] = unit
    for role, units in by_role.items():
        if len(set(units.values())) > 1:
            raise InputDataError(
                f"{table.path}: the {role} channels are in different units ({units}); one model needs one unit "
                "per quantity - convert them to a common unit before loading"
            )


def _sampling_frequency(t: np.ndarray, where: str, locate, fs: float | None, slack: float = 0.0) -> float:
    """fs from uniformly spaced time stamps [s] (``slack``: extra absolute tolerance [s])."""
    if not np.all(np.isfinite(t)):
        row = int(np.argmax(~np.isfinite(t)))
        raise InputDataError(f"{where} has a missing value at sample {row}{locate(row)}; fill it or set [data] fs")
    if len(t) < 2:
        raise InputDataError(f"{where}: need at least two samples to derive fs")
    dt = (t[-1] - t[0]) / (len(t) - 1)
    deviation = np.abs(t - (t[0] + dt * np.arange(len(t))))
    tolerance = TIME_TOLERANCE * abs(dt) + slack
    if not dt > 0 or np.any(np.diff(t) <= 0) or deviation.max() > tolerance:
        row = int(np.argmax(deviation)) if dt > 0 else 0
        raise InputDataError(
            f"{where} is not uniformly sampled: expected increasing time stamps within {TIME_TOLERANCE:g} of a "
            f"sample interval ({dt:.6g} s) of a uniform grid, found a deviation of {deviation.max():.3g} s at sample "
            f"{row}{locate(row)}; resample the record to a uniform rate"
        )
    derived = 1.0 / dt
    if fs is not None and abs(derived - fs) > 1e-3 * fs:
        raise InputDataError(
            f"{where} gives fs = {derived:.9g} Hz but [data] fs = {fs:g} Hz; correct fs, or drop it to use the time column"
        )
    return fs if fs is not None else derived


def _stack(table, columns) -> np.ndarray:
    return np.column_stack([table.values[c] for c in columns])


def _missing_message(path: Path, what: str, missing, available, hint: str) -> InputDataError:
    shown = ", ".join(map(repr, available)) if available else "none"
    return InputDataError(f"{path}: {what} {missing} not found; available: {shown}. {hint}")


def _check_lengths(path: Path, values: Mapping[str, np.ndarray], what: str) -> None:
    lengths = {name: len(v) for name, v in values.items()}
    if len(set(lengths.values())) > 1:
        raise InputDataError(
            f"{path}: the {what} have different lengths {lengths}; all channels must be sampled together - "
            "store them with the same number of samples"
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
