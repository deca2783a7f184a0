"""Readers of MATLAB ``.mat`` files (v5 via scipy, v7.3/HDF5 via h5py) and HDF5 files; each returns
:class:`MeasurementColumns`. The Universal File reader is :mod:`bayesnsi.io._uff`.

h5py and pyuff are optional: they are imported when such a file is read, and a missing one is
an :class:`~bayesnsi.exceptions.InputDataError` naming the extra to install (:data:`EXTRAS`).
Every array is sized from the file's metadata and checked with
:func:`bayesnsi._limits.check_allocation` before it is read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError
from ._columns import (
    EXTRAS,
    FS_TOLERANCE,
    MeasurementColumns,
    as_vector,
    check_lengths,
    file_format,
    missing_message,
    optional_module,
    sampling_frequency,
)
from ._uff import UFF_DIRECTIONS, read_uff, uff_channel_key

__all__ = ["EXTRAS", "read_matlike", "read_uff", "uff_channel_key", "UFF_DIRECTIONS"]


# ---------------------------------------------------------------------------------------------
# MATLAB (.mat v4/v5/v7 via scipy.io, v7.3 via h5py) and HDF5


_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_MAT_NUMERIC = {"double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64"}


def _is_hdf5(path: Path) -> bool:
    """HDF5 signature at offset 0, 512, 1024, ... (a MAT v7.3 file has a 512-byte user block)."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        offset = 0
        while offset + 8 <= size:
            fh.seek(offset)
            if fh.read(8) == _HDF5_SIGNATURE:
                return True
            offset = 512 if offset == 0 else offset * 2
    return False


def read_matlike(path: Path, columns: list[str], time: str, present: Mapping[str, str]) -> MeasurementColumns:
    """Read ``columns`` of a MAT file (v4-v7 via scipy, v7.3 via h5py) or an HDF5 file.

    Parameters
    ----------
    path : Path
        The file (HDF5 is recognised by its signature, whatever the extension).
    columns : list of str
        Variable names to read.
    time : str
        Name of an optional time vector that gives fs.
    present : mapping of str to str
        Further variables that must exist (not read), with their role.

    Returns
    -------
    MeasurementColumns

    Raises
    ------
    InputDataError
        For an unreadable file, missing or non-vector variables, arrays over the memory limit,
        or h5py missing for a v7.3 / HDF5 file.
    """
    if _is_hdf5(path):
        return _read_hdf5(path, columns, time, present)
    if file_format(path) == "hdf5":
        raise InputDataError(f"{path}: not an HDF5 file (no HDF5 signature); check the file or its extension")
    import scipy.io

    try:
        info = scipy.io.whosmat(str(path))
    except Exception as exc:  # scipy raises ValueError, MatReadError, TypeError... on non-MAT content
        raise InputDataError(  # the parser's own message may quote the file: only its type is shown
            f"{path}: cannot read it as a MATLAB .mat file ({type(exc).__name__}); save it with MATLAB's save"
        ) from exc
    classes = {name: cls for name, _, cls in info}
    names = tuple(classes)
    missing = [c for c in columns if c not in classes]
    if missing:
        raise missing_message(path, "variable(s)", missing, names,
                               "Variable names are case-sensitive: fix [data] in the config or the file")
    absent = [c for c in present if c not in classes]
    if absent:
        raise missing_message(path, "acceleration variable(s)", absent, names, "fix [data] accelerations")
    for name in columns:
        if classes[name] not in _MAT_NUMERIC:
            raise InputDataError(
                f"{path}: variable {name!r} is a MATLAB {classes[name]}, not a real numeric vector; "
                "store each channel as a numeric vector (double) of its own"
            )
    extra = [v for v in (time, "fs") if v in classes and v not in columns and v not in present]
    shapes = {name: shape for name, shape, _ in info}
    check_allocation(8 * sum(math.prod(shapes[v]) for v in list(columns) + extra), f"{path}: the MATLAB variables")
    try:
        loaded = scipy.io.loadmat(str(path), variable_names=list(columns) + extra, squeeze_me=False)
    except Exception as exc:
        raise InputDataError(f"{path}: cannot read the MATLAB variables ({type(exc).__name__})") from exc
    values = {c: as_vector(loaded[c], f"{path}: variable {c!r}", f"MATLAB {classes[c]}") for c in columns}
    check_lengths(path, values, "variables")
    return _with_file_fs(path, "mat", names, values, {}, time, {v: loaded[v] for v in extra})


def _read_hdf5(path: Path, columns: list[str], time: str, present: Mapping[str, str]) -> MeasurementColumns:
    h5py = optional_module("h5py", path, "MAT v7.3 / HDF5 files")
    kind = "mat" if file_format(path) == "mat" else "hdf5"
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise InputDataError(f"{path}: cannot open it as HDF5 / MAT v7.3 ({exc})") from exc
    with h5:
        names = tuple(k for k in h5.keys() if not k.startswith("#"))
        missing = [c for c in columns if c not in h5]
        if missing:
            raise missing_message(path, "variable(s)", missing, names,
                                   "Variable names are case-sensitive: fix [data] in the config or the file")
        absent = [c for c in present if c not in h5]
        if absent:
            raise missing_message(path, "acceleration variable(s)", absent, names, "fix [data] accelerations")
        values = {c: _h5_vector(h5py, h5[c], c, path) for c in columns}
        stored = [v for v in (time, "fs") if v in h5 and v not in columns and v not in present]
        extra = {v: _h5_vector(h5py, h5[v], v, path) for v in stored}
    check_lengths(path, values, "variables")
    return _with_file_fs(path, kind, names, values, {}, time, extra)


def _h5_vector(h5py, obj, name: str, path: Path) -> np.ndarray:
    if not isinstance(obj, h5py.Dataset):
        raise InputDataError(
            f"{path}: {name!r} is a group (a MATLAB struct, cell or sparse matrix), not a numeric vector; "
            "store each channel as a numeric vector of its own"
        )
    cls = obj.attrs.get("MATLAB_class", b"")
    cls = cls.decode() if isinstance(cls, bytes) else str(cls)
    if cls and cls not in _MAT_NUMERIC or obj.attrs.get("MATLAB_empty", 0):
        what = "an empty array" if obj.attrs.get("MATLAB_empty", 0) else f"a MATLAB {cls}"
        raise InputDataError(f"{path}: variable {name!r} is {what}, not a real numeric vector")
    check_allocation(8 * obj.size, f"{path}: variable {name!r} ({obj.size} values)")
    return as_vector(obj[()], f"{path}: variable {name!r}", f"HDF5 {obj.dtype}")



def _with_file_fs(path, kind, names, values, units, time, extra) -> MeasurementColumns:
    """Attach the sampling information stored in a MAT/HDF5 file: a time vector and/or a scalar fs."""
    fs, source, tolerance = None, "", FS_TOLERANCE
    n = len(next(iter(values.values()))) if values else 0
    if "fs" in extra:
        stored = np.asarray(extra["fs"])
        value = float(stored.reshape(-1)[0]) if stored.dtype.kind in "iuf" and stored.size == 1 else math.nan
        if not (math.isfinite(value) and value > 0):
            raise InputDataError(f"{path}: variable 'fs' must be one positive number [Hz], found {extra['fs']!r}")
        fs, source = value, "variable 'fs'"
    if time in extra:
        t = as_vector(extra[time], f"{path}: time variable {time!r}", "time")
        if values and len(t) != n:
            raise InputDataError(
                f"{path}: time variable {time!r} has {len(t)} samples, the channels {n}; store them together"
            )
        derived = sampling_frequency(t, f"{path}: time variable {time!r}", lambda row: "", None)
        if fs is not None and abs(derived - fs) > 1e-3 * fs:
            raise InputDataError(
                f"{path}: time variable {time!r} gives fs = {derived:.9g} Hz but variable 'fs' = {fs:g} Hz; "
                "correct one of them"
            )
        if fs is None:
            fs, source, tolerance = derived, f"time variable {time!r}", 1e-3
    hint = f"the file holds no time variable {time!r} and no scalar variable 'fs'; set fs in [data]"
    return MeasurementColumns(
        path=path, format=kind, names=tuple(names), values=values, units=dict(units), fs=fs, fs_source=source,
        fs_tolerance=tolerance, hint=hint,
    )

