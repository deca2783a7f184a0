"""Measurements: files -> :class:`~bayesnsi.signals.Signals`, and Signals -> CSV (docs/method.md §9).

The format follows the extension of the file (:data:`FORMATS`): ``.mat`` (MATLAB; v4/v5/v7 via
:func:`scipy.io.loadmat`, v7.3 = HDF5 via h5py), ``.h5``/``.hdf5`` (HDF5 via h5py),
``.uff``/``.unv`` (Universal File Format dataset 58 via pyuff); any other extension is read
as CSV text. Input files are opened read-only and never modified. Only the channels named
in the config are converted. Channels of one response kind (displacements, velocities,
accelerations) must share a unit where the file states units (CSV units row, UFF ordinate
units label); units are reported, never converted.

**CSV**: a header line naming the columns; optionally a units row right below it (every
cell non-numeric, e.g. ``"s","N","m"``), then one row per sample. Trailing empty columns (the
Silverbox files end every line with a comma: ``"V1","V2",``) are ignored. Before parsing, a
file with a line over 4 MiB (:data:`bayesnsi.io._csv.MAX_LINE_BYTES`) or a NUL byte, or whose
columns would need more memory than ``BAYESNSI_MAX_MEMORY`` allows (:mod:`bayesnsi._limits`), is
refused; error messages name the file and line, never quote its content.

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

h5py (MAT v7.3, HDF5) and pyuff (UFF58) are optional: ``pip install 'bayesnsi[hdf5]'`` or
``'bayesnsi[uff]'``; without them reading such a file is an error that names the extra.

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
(:func:`bayesnsi.preprocess.decimate`), then (integrated without whole periods) cut by
``2 / (taper f_lo)`` seconds at each end unless ``integrate.trim_edges = false``, then
mean-removed when ``remove_mean``. See
:class:`~bayesnsi.io.config.DataSpec`.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..exceptions import InputDataError, PeriodicityWarning
from ..nsi.steady import force_repeats
from ..signals import Signals
from ._columns import FORMATS, FS_TOLERANCE, TIME_TOLERANCE, MeasurementColumns, file_format
from ._csv import CSVColumns, read_csv_columns
from ._load_checks import check_loaded
from ._realisations import Split, split_parts
from ._record import Record, read_any
from ._specs import DataSpec, ExperimentConfig
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
    return read_any(Path(path), wanted, {}, time_column, {})


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
    record = Record(Path(path), data)
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
        As :func:`read_signals`, for the samples inside the window; or when two mapped channels
        hold the same samples (one channel mapped twice, :mod:`bayesnsi.io._load_checks`).

    Warns
    -----
    FreeBodyWarning
        When ``[nsi] virtual_stiffness`` is a number and the record's structure looks grounded.
    """
    record = Record(config.data.file, config.data, config.data.files)
    start, stop = record.window(config.data.estimation, "[data] estimation", config.path)
    split = _estimation_split(config)
    means = record.means(start, stop, split) if config.data.remove_mean else None
    signals = record.signals(start, stop, means, split)
    check_loaded(config, signals)
    return signals


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
    main = Record(config.data.file, config.data, config.data.files)
    means = None
    if config.data.remove_mean:
        means = main.means(*main.window(config.data.estimation, "[data] estimation", config.path),
                           _estimation_split(config))
    out = []
    for segment in config.validation:
        same_file = not segment.files and (segment.file is None or segment.file == config.data.file)
        data = config.data
        if segment.period is not None:  # its own period, or 0: not periodic (a sweep)
            data = dataclasses.replace(data, period=segment.period or None)
        if segment.integrate is not None:  # its own integration band
            data = dataclasses.replace(data, integrate=segment.integrate)
        if segment.files:  # another record, one file per channel
            record = Record(next(iter(segment.files.values())), data, segment.files)
        else:
            record = main if same_file and data is config.data else Record(segment.file or data.file, data)
        if record is not main:
            main.check_same_units(record, f"[[validation]] {segment.name!r}")
        start, stop = record.window(
            (segment.start, segment.stop), f"[[validation]] {segment.name!r} start/stop", config.path
        )
        split = Split(segment.realisations, segment.transient_periods, f"[[validation]] {segment.name!r}")
        if segment.period is None and not _repeats(record, data.period, start, stop, split):
            warnings.warn(
                f"[[validation]] {segment.name!r}: its force does not repeat every {data.period} samples ([data] "
                "period), so it is validated as a record that is not periodic (the model simulated over the whole "
                "record); give period = <samples> in the segment if it has a period of its own",
                PeriodicityWarning, stacklevel=2,
            )
            data = dataclasses.replace(data, period=None)
            record = Record(segment.file or data.file, data, segment.files or None)
        out.append((segment.name, record.signals(start, stop, means, split)))
    return out


def _repeats(record: Record, period: int | None, start: int, stop: int, split: Split) -> bool:
    """The force of each realisation of a window repeats with ``period`` (True without a period or two of them)."""
    if not period or stop - start < 2 * period:
        return True  # nothing to tell: a window shorter than two periods loads without its period anyway
    parts = split_parts(period, record.path, start, stop, split)
    return all(force_repeats(record.force[a:b], period) for a, b in parts if b - a >= 2 * period)


def _estimation_split(config: ExperimentConfig) -> Split:
    """The realisations of the estimation window (``[data] realisations``, ``transient_periods``)."""
    return Split(config.data.realisations, config.data.transient_periods, "[data] estimation")


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
    import pandas as pd  # here: reading a file does not need it (0.2 s to import)

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
