"""Readers of the binary measurement formats: MATLAB ``.mat`` (v5 via scipy, v7.3/HDF5 via h5py)
and Universal File Format dataset 58 (pyuff). Each returns :class:`MeasurementColumns`; the
CSV reader and the channel/role checks live in :mod:`bayesnsi.io.measurements`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..exceptions import InputDataError
from .measurements import (
    FS_TOLERANCE,
    TIME_TOLERANCE,
    MeasurementColumns,
    _check_lengths,
    _missing_message,
    _sampling_frequency,
    file_format,
)

__all__ = ["read_matlike", "read_uff", "uff_channel_key", "UFF_DIRECTIONS"]


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
    if _is_hdf5(path):
        return _read_hdf5(path, columns, time, present)
    if file_format(path) == "hdf5":
        raise InputDataError(f"{path}: not an HDF5 file (no HDF5 signature); check the file or its extension")
    import scipy.io

    try:
        info = scipy.io.whosmat(str(path))
    except Exception as exc:  # scipy raises ValueError, MatReadError, TypeError... on non-MAT content
        raise InputDataError(
            f"{path}: cannot read it as a MATLAB .mat file ({exc}); save it with MATLAB's save"
        ) from exc
    classes = {name: cls for name, _, cls in info}
    names = tuple(classes)
    missing = [c for c in columns if c not in classes]
    if missing:
        raise _missing_message(path, "variable(s)", missing, names,
                               "Variable names are case-sensitive: fix [data] in the config or the file")
    absent = [c for c in present if c not in classes]
    if absent:
        raise _missing_message(path, "acceleration variable(s)", absent, names, "fix [data] accelerations")
    for name in columns:
        if classes[name] not in _MAT_NUMERIC:
            raise InputDataError(
                f"{path}: variable {name!r} is a MATLAB {classes[name]}, not a real numeric vector; "
                "store each channel as a numeric vector (double) of its own"
            )
    extra = [v for v in (time, "fs") if v in classes and v not in columns and v not in present]
    try:
        loaded = scipy.io.loadmat(str(path), variable_names=list(columns) + extra, squeeze_me=False)
    except Exception as exc:
        raise InputDataError(f"{path}: cannot read the MATLAB variables ({exc})") from exc
    values = {c: _vector(loaded[c], f"{path}: variable {c!r}", f"MATLAB {classes[c]}") for c in columns}
    _check_lengths(path, values, "variables")
    return _with_file_fs(path, "mat", names, values, {}, time, {v: loaded[v] for v in extra})


def _read_hdf5(path: Path, columns: list[str], time: str, present: Mapping[str, str]) -> MeasurementColumns:
    try:
        import h5py
    except ImportError as exc:  # pragma: no cover - h5py is a dependency
        raise InputDataError(f"{path}: reading MAT v7.3 / HDF5 files needs h5py: pip install h5py") from exc
    kind = "mat" if file_format(path) == "mat" else "hdf5"
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise InputDataError(f"{path}: cannot open it as HDF5 / MAT v7.3 ({exc})") from exc
    with h5:
        names = tuple(k for k in h5.keys() if not k.startswith("#"))
        missing = [c for c in columns if c not in h5]
        if missing:
            raise _missing_message(path, "variable(s)", missing, names,
                                   "Variable names are case-sensitive: fix [data] in the config or the file")
        absent = [c for c in present if c not in h5]
        if absent:
            raise _missing_message(path, "acceleration variable(s)", absent, names, "fix [data] accelerations")
        values = {c: _h5_vector(h5[c], c, path) for c in columns}
        stored = [v for v in (time, "fs") if v in h5 and v not in columns and v not in present]
        extra = {v: _h5_vector(h5[v], v, path) for v in stored}
    _check_lengths(path, values, "variables")
    return _with_file_fs(path, kind, names, values, {}, time, extra)


def _h5_vector(obj, name: str, path: Path) -> np.ndarray:
    import h5py

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
    return _vector(obj[()], f"{path}: variable {name!r}", f"HDF5 {obj.dtype}")


def _vector(value, where: str, kind: str) -> np.ndarray:
    """A 1-D float copy of a vector (1×N, N×1 or N); anything else is an error. ``where`` names it."""
    if hasattr(value, "toarray"):  # scipy.sparse
        raise InputDataError(f"{where} is a sparse matrix; store it as a full numeric vector")
    array = np.asarray(value)
    if array.dtype.kind not in "iuf":
        raise InputDataError(
            f"{where} ({kind}, dtype {array.dtype}) is not a real numeric vector; "
            "store each channel as a real numeric vector of its own"
        )
    if array.size == 0:
        raise InputDataError(f"{where} is empty")
    if array.ndim > 2 or (array.ndim == 2 and min(array.shape) != 1):
        raise InputDataError(
            f"{where} has shape {array.shape}; expected a vector (1×N or N×1) - store each "
            "channel as its own variable"
        )
    return np.array(array.reshape(-1), dtype=float)


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
        t = _vector(extra[time], f"{path}: time variable {time!r}", "time")
        if values and len(t) != n:
            raise InputDataError(
                f"{path}: time variable {time!r} has {len(t)} samples, the channels {n}; store them together"
            )
        derived = _sampling_frequency(t, f"{path}: time variable {time!r}", lambda row: "", None)
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


# ---------------------------------------------------------------------------------------------
# Universal File Format, dataset 58 (pyuff)


UFF_DIRECTIONS = {"X": 1, "Y": 2, "Z": 3, "RX": 4, "RY": 5, "RZ": 6}
"""Direction labels of a ``"node:dir"`` channel key -> UFF direction code (the sign is the code's)."""
_UFF_KEY = re.compile(r"^\s*(\d+)\s*:\s*([+-]?)\s*(X|Y|Z|RX|RY|RZ|\d+)\s*$", re.IGNORECASE)
_UFF_FUNCTIONS = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum",
                  4: "frequency response function", 5: "transmissibility", 6: "coherence",
                  7: "auto correlation", 8: "cross correlation", 9: "power spectral density",
                  10: "energy spectral density", 11: "probability density function", 12: "spectrum",
                  13: "cumulative frequency distribution", 14: "peaks valley", 15: "stress/cycles",
                  16: "strain/cycles", 17: "orbit", 18: "mode indicator function", 19: "force pattern",
                  20: "partial power", 21: "partial coherence", 22: "eigenvalue", 23: "eigenvector",
                  24: "shock response spectrum", 25: "finite impulse response filter",
                  26: "multiple coherence", 27: "order function"}
_UFF_KINDS = {8: "displacement", 9: "reaction force", 11: "velocity", 12: "acceleration", 13: "excitation force"}
# response roles and the UFF specific data types that contradict them
_UFF_CONTRADICTS = {
    "displacement": {9, 11, 12, 13},
    "velocity": {8, 9, 12, 13},
    "acceleration": {8, 9, 11, 13},
}


def uff_channel_key(record: Mapping) -> str:
    """The ``"node:dir"`` key of a UFF58 record, e.g. ``"2:+Z"`` (``"2:0"`` for a scalar record)."""
    node, code = int(record.get("rsp_node", 0)), int(record.get("rsp_dir", 0))
    label = {v: k for k, v in UFF_DIRECTIONS.items()}.get(abs(code))
    if label is None:
        return f"{node}:{code}"
    return f"{node}:{'-' if code < 0 else '+'}{label}"


def _parse_uff_key(key: str) -> tuple[int, int] | None:
    match = _UFF_KEY.match(key)
    if not match:
        return None
    node, sign, direction = match.groups()
    code = int(direction) if direction.isdigit() else UFF_DIRECTIONS[direction.upper()]
    return int(node), -code if sign == "-" else code


def read_uff(
    path: Path, columns: list[str], roles: Mapping[str, str], present: Mapping[str, str]
) -> MeasurementColumns:
    try:
        import pyuff
    except ImportError as exc:  # pragma: no cover - pyuff is a dependency
        raise InputDataError(f"{path}: reading Universal Files needs pyuff: pip install pyuff") from exc
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
        positions = [i for i, t in enumerate(types) if t == 58]
        headers = _uff_headers(uff, positions) if positions else []
    except Exception as exc:  # pyuff raises bare Exception on malformed files
        raise InputDataError(f"{path}: cannot read it as a Universal File ({exc}); check the file") from exc
    if not headers:
        raise InputDataError(
            f"{path}: no dataset 58 (function at nodal DOF) records found (dataset types in the file: "
            f"{sorted(set(types)) or 'none'}); export the time records as UFF58"
        )
    labels = [f"{str(h.get('id1', '')).strip()!r} ({uff_channel_key(h)})" for h in headers]
    chosen = {}
    for name in list(columns) + [c for c in present if c not in columns]:
        index = _find_uff_record(path, name, headers, labels)
        if index is None:
            what = "acceleration record" if name in present and name not in columns else "record"
            raise InputDataError(
                f"{path}: no {what} {name!r}; the dataset 58 records are (id1 (node:dir)): {', '.join(labels)}. "
                'Name a record in [data] by its id1 text or by "node:dir", e.g. "2:+Z"'
            )
        chosen[name] = index
    records = {}
    wanted = sorted({chosen[c] for c in columns})
    try:
        loaded = _as_list(uff.read_sets([positions[i] for i in wanted])) if wanted else []
    except Exception as exc:
        raise InputDataError(f"{path}: cannot read the dataset 58 records ({exc}); check the file") from exc
    by_index = dict(zip(wanted, loaded))
    for name in columns:
        records[name] = by_index[chosen[name]]
    values, units, steps, starts = {}, {}, {}, {}
    for name, record in records.items():
        where = f"{path}: record {name!r} ({labels[chosen[name]]})"
        values[name], steps[name], starts[name] = _uff_samples(record, where)
        kind = int(record.get("ordinate_spec_data_type", 0) or 0)
        role = roles.get(name, "")
        if kind in _UFF_CONTRADICTS.get(role, ()):
            raise InputDataError(
                f"{where} holds {_UFF_KINDS[kind]} (specific data type {kind}) but the config maps it as {role}; "
                "fix the mapping in [data]"
            )
        unit = str(record.get("ordinate_axis_units_lab", "") or "").strip()
        if unit and unit.upper() != "NONE":
            units[name] = unit
    _check_lengths(path, values, "records")
    reference = next(iter(steps))
    for name in steps:
        if abs(steps[name] - steps[reference]) > 1e-6 * steps[reference]:
            raise InputDataError(
                f"{path}: inconsistent sampling intervals between records: {name!r} has {steps[name]:.9g} s, "
                f"{reference!r} {steps[reference]:.9g} s; all channels must share one sampling rate"
            )
        if abs(starts[name] - starts[reference]) > TIME_TOLERANCE * steps[reference]:
            raise InputDataError(
                f"{path}: records start at different times: {name!r} at {starts[name]:.9g} s, {reference!r} at "
                f"{starts[reference]:.9g} s; the channels must be sampled together"
            )
    step = float(np.mean(list(steps.values())))
    return MeasurementColumns(
        path=path, format="uff", names=tuple(labels), values=values, units=units, fs=1.0 / step,
        fs_source="abscissa_inc of the records", fs_tolerance=FS_TOLERANCE,
        hint="the records give no sampling interval; set fs in [data]",
    )


def _uff_headers(uff, positions: list[int]) -> list:
    try:
        return _as_list(uff.read_sets(positions, header_only=True))
    except TypeError:  # pyuff without header_only: read the records whole
        return _as_list(uff.read_sets(positions))


def _as_list(sets) -> list:
    return sets if isinstance(sets, list) else [sets]


def _find_uff_record(path: Path, key: str, headers: list, labels: list[str]) -> int | None:
    text = key.strip()
    hits = [i for i, h in enumerate(headers) if str(h.get("id1", "")).strip() == text]
    how = "id1"
    if not hits:
        parsed = _parse_uff_key(key)
        if parsed is not None:
            hits = [
                i for i, h in enumerate(headers) if (int(h.get("rsp_node", -1)), int(h.get("rsp_dir", 0))) == parsed
            ]
            how = "response node and direction"
    if len(hits) > 1:
        raise InputDataError(
            f"{path}: {key!r} matches {len(hits)} records by {how}: {[labels[i] for i in hits]}; give the records "
            "distinct id1 texts (or node/direction) and name one of them"
        )
    return hits[0] if hits else None


def _uff_samples(record: Mapping, where: str) -> tuple[np.ndarray, float, float]:
    """Ordinate values, sampling interval [s] and start time [s] of a UFF58 time record."""
    func = int(record.get("func_type", 0) or 0)
    if func not in (0, 1):
        name = _UFF_FUNCTIONS.get(func, "unknown")
        raise InputDataError(
            f"{where} is function type {func} ({name}); only time records (function type 1, or 0 general) "
            "can be loaded"
        )
    abscissa = int(record.get("abscissa_spec_data_type", 0) or 0)
    if abscissa not in (0, 1, 17):
        raise InputDataError(
            f"{where}: the abscissa is specific data type {abscissa}, not time (17); only time records can be loaded"
        )
    data = np.asarray(record.get("data"))
    if np.iscomplexobj(data):
        raise InputDataError(f"{where} holds complex values; only real time records can be loaded")
    values = _vector(data, where, "UFF58")
    if int(record.get("abscissa_spacing", 1)) == 1:
        step = float(record.get("abscissa_inc", 0.0))
        start = float(record.get("abscissa_min", 0.0))
        if not (math.isfinite(step) and step > 0):
            raise InputDataError(f"{where}: abscissa increment {step!r} s is not a positive number")
        return values, step, start
    x = np.asarray(record.get("x"), dtype=float)
    # uneven abscissa: stored with 6 significant digits (E13.5), hence the extra slack
    fs = _sampling_frequency(x, f"{where}: abscissa", lambda row: "", None, slack=1e-5 * float(np.max(np.abs(x))))
    return values, 1.0 / fs, float(x[0])


