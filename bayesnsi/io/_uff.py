"""Reader of Universal File Format dataset 58 time records (via the optional pyuff)."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError
from ._columns import (
    FS_TOLERANCE,
    TIME_TOLERANCE,
    MeasurementColumns,
    as_vector,
    check_lengths,
    optional_module,
    sampling_frequency,
)

__all__ = ["UFF_DIRECTIONS", "read_uff", "uff_channel_key"]


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
    """The ``"node:dir"`` key of a UFF58 record, e.g. ``"2:+Z"`` (``"2:0"`` for a scalar record).

    Parameters
    ----------
    record : mapping
        A dataset 58 record as pyuff reads it (``rsp_node`` and ``rsp_dir`` are used).

    Returns
    -------
    str
        ``"<node>:<sign><direction>"`` with a direction of :data:`UFF_DIRECTIONS`, or
        ``"<node>:<code>"`` for a code outside them.
    """
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
    """Read the dataset 58 time records named by ``columns`` from a Universal File.

    Parameters
    ----------
    path : Path
        The file.
    columns : list of str
        Record keys: ``id1`` text or ``"node:dir"``.
    roles : mapping of str to str
        Column -> role ("input", "displacement", ...), checked against the record's data type.
    present : mapping of str to str
        Further records that must exist (not read), with their role.

    Returns
    -------
    MeasurementColumns

    Raises
    ------
    InputDataError
        For an unreadable file, missing, ambiguous or non-time records, inconsistent sampling,
        or pyuff missing.
    """
    pyuff = optional_module("pyuff", path, "Universal Files (UFF58)")
    size = path.stat().st_size
    check_allocation(2 * size, f"{path}: a Universal File of {size} bytes (pyuff holds it in memory twice)")
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
        positions = [i for i, t in enumerate(types) if t == 58]
        headers = _uff_headers(uff, positions) if positions else []
    except Exception as exc:  # pyuff raises bare Exception on malformed files
        raise InputDataError(
            f"{path}: cannot read it as a Universal File ({type(exc).__name__}); check the file"
        ) from exc
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
        raise InputDataError(
            f"{path}: cannot read the dataset 58 records ({type(exc).__name__}); check the file"
        ) from exc
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
    check_lengths(path, values, "records")
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
    values = as_vector(data, where, "UFF58")
    if int(record.get("abscissa_spacing", 1)) == 1:
        step = float(record.get("abscissa_inc", 0.0))
        start = float(record.get("abscissa_min", 0.0))
        if not (math.isfinite(step) and step > 0):
            raise InputDataError(f"{where}: abscissa increment {step!r} s is not a positive number")
        return values, step, start
    x = np.asarray(record.get("x"), dtype=float)
    # uneven abscissa: stored with 6 significant digits (E13.5), hence the extra slack
    fs = sampling_frequency(x, f"{where}: abscissa", lambda row: "", None, slack=1e-5 * float(np.max(np.abs(x))))
    return values, 1.0 / fs, float(x[0])
