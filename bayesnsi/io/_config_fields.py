"""Building blocks of the configuration reader: reading the TOML, error messages that name the
file, section and key, and typed getters of table values."""

from __future__ import annotations

import difflib
import math
import tomllib
import unicodedata
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..exceptions import ConfigError
from ..options import EvidenceOptions, LoopOptions, NSIOptions

__all__ = [
    "MISSING", "MAX_CONFIG_BYTES", "MAX_NESTING", "Where", "build_options", "check_keys", "check_name", "describe",
    "get_bool", "get_choice", "get_int", "get_number", "get_text", "get_window", "read_toml",
]

MISSING = object()
"""Marks a key that is absent from its table."""

MAX_CONFIG_BYTES = 8 * 2**20
"""Largest accepted configuration file (8 MiB)."""

MAX_NESTING = 32
"""Deepest accepted nesting of tables and arrays in a configuration file."""


class Where:
    """A place in the config file, to build messages: file, section, key, expected, found, fix."""

    def __init__(self, path: Path, section: str):
        self.path = path
        self.section = section

    def error(self, key: str | None, expected: str, found: Any = MISSING, fix: str = "") -> ConfigError:
        place = f"{self.path}: {self.section}" + (f" {key}" if key else "")
        found_text = "nothing (the key is missing)" if found is MISSING else describe(found)
        return ConfigError(f"{place}: expected {expected}, found {found_text}" + (f"; {fix}" if fix else ""))

    def problem(self, key: str | None, message: str) -> ConfigError:
        place = f"{self.path}: {self.section}" + (f" {key}" if key else "")
        return ConfigError(f"{place}: {message}")


def describe(value: Any) -> str:
    """A value for a message: its repr (cut at 80 characters) and its TOML kind."""
    kind = {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array",
            dict: "a table"}.get(type(value), type(value).__name__)
    return f"{_shorten(repr(value))} ({kind})"


def _shorten(text: str) -> str:
    return text if len(text) <= 80 else text[:77] + "..."


def check_keys(table: Mapping, allowed: tuple[str, ...], where: Where) -> None:
    """Refuse keys outside ``allowed``, suggesting the closest allowed spelling of (the first few) unknown keys."""
    unknown = [k for k in table if k not in allowed]
    if not unknown:
        return
    hints = [f"and {len(unknown) - 5} more"] if len(unknown) > 5 else []
    for key in reversed(unknown[:5]):
        close = difflib.get_close_matches(key, allowed, n=1)
        hints.insert(0, _shorten(repr(key)) + (f" (did you mean {close[0]!r}?)" if close else ""))
    raise where.problem(
        None, f"unknown key(s) {', '.join(hints)}; allowed keys are: {', '.join(allowed)}. "
        "Fix the spelling or remove the key"
    )


def get_int(table: Mapping, key: str, where: Where, default: Any = MISSING, minimum: int | None = None):
    """``table[key]`` as an integer (not a boolean), at least ``minimum``; ``default`` when absent."""
    value = table.get(key, default)
    if value is MISSING:
        raise where.error(key, "an integer", fix=f"add {key} = <integer>")
    if value is None and default is None:
        return None
    if not isinstance(value, int) or isinstance(value, bool):
        raise where.error(key, "an integer", value, "write it without quotes or decimal point")
    if minimum is not None and value < minimum:
        raise where.error(key, f"an integer >= {minimum}", value)
    return value


def get_number(table: Mapping, key: str, where: Where, default: Any = MISSING, positive: bool = False):
    """``table[key]`` as a finite float (positive if asked); ``default`` when absent."""
    value = table.get(key, default)
    if value is MISSING:
        raise where.error(key, "a number", fix=f"add {key} = <number>")
    if value is None:
        return None
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise where.error(key, "a finite number", value, "write it without quotes, e.g. 100.0")
    if positive and value <= 0:
        raise where.error(key, "a positive number", value)
    return float(value)


def get_bool(table: Mapping, key: str, where: Where, default: bool) -> bool:
    """``table[key]`` as true or false; ``default`` when absent."""
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise where.error(key, "true or false", value, "write true or false without quotes")
    return value


def get_choice(table: Mapping, key: str, where: Where, choices: tuple[str, ...], default: str) -> str:
    """``table[key]`` as one of ``choices``; ``default`` when absent."""
    value = table.get(key, default)
    if not isinstance(value, str) or value not in choices:
        raise where.error(key, f"one of {', '.join(map(repr, choices))}", value)
    return value


def get_text(table: Mapping, key: str, where: Where, default: Any = MISSING) -> str:
    """``table[key]`` as a non-blank string; ``default`` when absent."""
    value = table.get(key, default)
    if value is MISSING:
        raise where.error(key, "a string", fix=f'add {key} = "..."')
    if not isinstance(value, str) or not value.strip():
        raise where.error(key, "a non-empty string", value, "put the text in double quotes")
    return value


def get_window(value: Any, where: Where, key: str) -> tuple[int, int]:
    """A ``[start, stop]`` sample window with ``0 <= start < stop``."""
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, int) and not isinstance(v, bool) for v in value))
    if not ok or not 0 <= value[0] < value[1]:
        raise where.error(key, "[start, stop] sample indices with 0 <= start < stop (stop excluded)", value)
    return value[0], value[1]


def check_name(value: str, where: Where, key: str) -> str:
    """A name without control or invisible format characters (NUL, escape, newline, bidi marks)."""
    bad = next((c for c in value if unicodedata.category(c) in _HIDDEN_CATEGORIES), None)
    if bad is not None:
        raise where.problem(
            key, f"the name holds the control character U+{ord(bad):04X}; use printable characters only"
        )
    return value


_HIDDEN_CATEGORIES = ("Cc", "Cf", "Cs", "Zl", "Zp")


def read_toml(path: Path, limits: Mapping[str, tuple[int, str]] | None = None) -> dict[str, Any]:
    """The parsed TOML of a config file, refused (ConfigError) when too large, too deep or invalid.

    Parameters
    ----------
    path : Path
        The config file.
    limits : mapping of str to (int, str), optional
        Array-of-tables name -> (most tables accepted, advice): counted in the text before
        parsing, so that a huge array is refused without building it.

    Returns
    -------
    dict
        The parsed TOML.

    Raises
    ------
    ConfigError
        For a file over :data:`MAX_CONFIG_BYTES`, more tables than ``limits`` allow, invalid
        TOML or UTF-8, or nesting deeper than :data:`MAX_NESTING`.
    """
    size = path.stat().st_size
    if size > MAX_CONFIG_BYTES:
        raise ConfigError(
            f"{path}: the config file has {size} bytes, more than the {MAX_CONFIG_BYTES} accepted; "
            "check that it is the experiment configuration"
        )
    with open(path, "rb") as fh:
        data = fh.read(MAX_CONFIG_BYTES + 1)
    for name, (most, advice) in (limits or {}).items():
        count = data.count(f"[[{name}]]".encode())
        if count > most:
            raise ConfigError(f"{path}: {count} [[{name}]] tables, more than the {most} accepted; {advice}")
    try:
        raw = tomllib.loads(data.decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc}); fix the syntax at that line") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{path}: not UTF-8 text (undecodable byte at offset {exc.start}); save the config as UTF-8"
        ) from None
    except RecursionError:
        raise ConfigError(
            f"{path}: tables or arrays nest too deeply to read; at most {MAX_NESTING} levels are accepted"
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits, which int() refuses
        raise ConfigError(f"{path}: not valid TOML ({exc}); TOML integers have at most 19 digits") from None
    _check_depth(raw, path)
    return raw


def _check_depth(raw: dict, path: Path) -> None:
    """Refuse nesting deeper than MAX_NESTING (iteratively: deep input cannot exhaust the stack)."""
    stack: list[tuple[Any, int]] = [(raw, 1)]
    while stack:
        value, depth = stack.pop()
        if depth > MAX_NESTING:
            raise ConfigError(
                f"{path}: tables or arrays nest {depth} levels deep or more; at most {MAX_NESTING} are accepted"
            )
        children = value.values() if isinstance(value, dict) else value
        stack.extend((child, depth + 1) for child in children if isinstance(child, (dict, list)))


def build_options(kind: type[NSIOptions] | type[EvidenceOptions] | type[LoopOptions], table: Any, where: Where,
                  **fixed: Any) -> Any:
    """Build an options object from a config table; errors carry the file and section."""
    if not isinstance(table, dict):
        raise where.error(None, f"a table [{kind.SECTION}]", table)
    check_keys(table, tuple(k for k in kind.names() if k not in fixed), where)
    try:
        return kind.from_mapping(table, **fixed)
    except ConfigError as exc:
        raise ConfigError(f"{where.path}: {exc}") from None
