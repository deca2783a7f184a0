"""A small TOML writer for the subset that experiment configurations use.

:func:`dumps` writes tables, arrays of tables, strings, integers, floats (including ``inf`` and
``nan``), booleans, arrays and inline tables, so that ``tomllib.loads(dumps(d)) == d`` for plain
dicts of those values. There is no TOML writer in the standard library (only :mod:`tomllib`).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ConfigError

__all__ = ["dumps"]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def dumps(config: Mapping[str, Any]) -> str:
    """TOML text for a plain dict; see :func:`bayesnsi.io.dump_config`."""
    if not isinstance(config, Mapping):
        raise ConfigError(f"dump_config needs a mapping, got {type(config).__name__}")
    lines: list[str] = []
    tables, arrays = [], []
    for key, value in config.items():
        if isinstance(value, Mapping):
            tables.append((key, value))
        elif _is_table_array(value):
            arrays.append((key, value))
        else:
            lines.append(f"{_toml_key(key)} = {_toml_value(value, str(key))}")
    for key, table in tables:
        lines += ["", f"[{_toml_key(key)}]"] + _toml_table_body(table, str(key))
    for key, items in arrays:
        for index, table in enumerate(items):
            lines += ["", f"[[{_toml_key(key)}]]"] + _toml_table_body(table, f"{key}[{index}]")
    if lines and lines[0] == "":
        lines = lines[1:]
    return "\n".join(lines) + "\n"


def _is_table_array(value: Any) -> bool:
    return isinstance(value, (list, tuple)) and len(value) > 0 and all(isinstance(v, Mapping) for v in value)


def _toml_table_body(table: Mapping, where: str) -> list[str]:
    lines = []
    for key, value in table.items():
        name = _toml_key(key)
        if _is_table_array(value):
            lines.append(f"{name} = [")
            lines += [f"    {_toml_value(v, f'{where}.{key}[{i}]')}," for i, v in enumerate(value)]
            lines.append("]")
        else:
            lines.append(f"{name} = {_toml_value(value, f'{where}.{key}')}")
    return lines


def _toml_key(key: Any) -> str:
    if not isinstance(key, str):
        raise ConfigError(f"TOML keys must be strings, got {key!r}; convert the key with str()")
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def _toml_value(value: Any, where: str) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        if not -(2**63) <= int(value) < 2**63:
            raise ConfigError(f"{where} is an integer beyond 64 bits, which TOML cannot hold; use a float or a string")
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        value = float(value)
        if math.isfinite(value):
            return repr(value)
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, os.PathLike):
        return _toml_string(Path(value).as_posix())
    if isinstance(value, Mapping):
        items = [f"{_toml_key(k)} = {_toml_value(v, f'{where}.{k}')}" for k, v in value.items()]
        return "{ " + ", ".join(items) + " }" if items else "{}"
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(v, f"{where}[{i}]") for i, v in enumerate(value)) + "]"
    if value is None:
        raise ConfigError(f"{where} is None, which TOML cannot hold; drop the key or give it a value")
    raise ConfigError(f"{where} is a {type(value).__name__}, which TOML cannot hold; use str, numbers, lists or dicts")


def _toml_string(text: str) -> str:
    out = []
    for char in text:
        code = ord(char)
        if char in '"\\':
            out.append("\\" + char)
        elif char in "\b\t\n\f\r":
            out.append({"\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}[char])
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\u{code:04X}")
        else:
            out.append(char)
    return '"' + "".join(out) + '"'
