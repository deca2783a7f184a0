"""``files = { column = "file", ... }`` of ``[data]`` and ``[[validation]]``: one file per channel.

Benchmark data are often shipped one channel per file (``uval_multisine.csv``,
``yval_multisine.csv``: a headerless column of numbers each); ``files`` names the file of every
mapped column instead of one ``file`` (:mod:`bayesnsi.io._split` reads them).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ._config_fields import MISSING, Where, check_name

__all__ = ["check_files_cover", "parse_files"]

_EXAMPLE = 'files = { u = "u.csv", y = "y.csv" }'


def parse_files(table: Mapping[str, Any], where: Where, resolve: Callable[[str, str], Path]) -> dict[str, Path]:
    """The ``files`` table of ``table`` as column -> absolute path (empty when absent).

    Parameters
    ----------
    table : mapping
        ``[data]`` or one ``[[validation]]`` table.
    where : Where
        The table's place, for messages.
    resolve : callable
        ``resolve(name, key)`` -> the absolute path of file ``name`` written under ``key``
        (relative to the config's folder, checked to exist when the config asks).

    Returns
    -------
    dict of str to Path

    Raises
    ------
    ConfigError
        If ``files`` is not a non-empty table of file names, names a column with control
        characters, or is given together with ``file``.
    """
    value = table.get("files", MISSING)
    if value is MISSING:
        return {}
    if "file" in table:
        raise where.problem(
            "files", "give either file (one file holding every column) or files (one file per column), not both"
        )
    if not isinstance(value, dict) or not value:
        raise where.error("files", "a non-empty table mapping each column to its file", value, f"write {_EXAMPLE}")
    out = {}
    for column, name in value.items():
        check_name(column, where, f"files column {column!r}")
        if not isinstance(name, str):
            raise where.error(f"files.{column}", "a file name in double quotes", name, f"write {_EXAMPLE}")
        out[column] = resolve(name, f"files.{column}")
    return out


def check_files_cover(files: Mapping[str, Path], columns: Iterable[str], where: Where) -> None:
    """Every mapped column has a file in ``files``, and ``files`` names no other column.

    Parameters
    ----------
    files : mapping of str to Path
        From :func:`parse_files`.
    columns : iterable of str
        The columns of inputs, outputs, velocities and accelerations.
    where : Where

    Raises
    ------
    ConfigError
        Naming the columns without a file, or the files of columns nothing maps.
    """
    columns = list(columns)
    missing = [c for c in columns if c not in files]
    if missing:
        raise where.problem(
            "files", f"no file for column(s) {missing}; with files, give the file of every column that inputs, "
            "outputs, velocities or accelerations map"
        )
    extra = [c for c in files if c not in columns]
    if extra:
        raise where.problem(
            "files", f"column(s) {extra} have a file but no role; map them in inputs/outputs/velocities/"
            "accelerations, or remove them from files"
        )
