"""Kinds of plain data: how a field is encoded for the cache and checked when read back.

Each kind has ``encode(value, arrays)`` (to JSON-ready data; arrays go to ``arrays`` by name,
:func:`~bayesnsi.io._store.encode_value`) and ``decode(plain, arrays, where)``, which checks what is
read (type, array dtype and number of dimensions, allowed values) and raises
:class:`~bayesnsi.io._store.EntryError` naming ``where``. :class:`Struct` describes a frozen
dataclass field by field (:mod:`bayesnsi.io._outcome` lists the result classes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..exceptions import BayesNSIError
from ._store import EntryError, decode_value, encode_value

__all__ = ["Array", "BOOL", "COMPLEX", "Choice", "FLOAT", "Frame", "INT", "Named", "OPTIONAL_FLOAT", "OPTIONAL_INT",
           "OPTIONAL_STR", "STR", "Sequence", "Struct", "Typed"]


class Typed:
    """A value of the given Python types (generic encoding, type checked when read)."""

    def __init__(self, *types: type, none: bool = False):
        self.types, self.none = types, none

    def encode(self, value: Any, arrays: dict) -> Any:
        return encode_value(value, arrays)

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        value = decode_value(plain, arrays, where)
        if value is None and self.none:
            return value
        if isinstance(value, bool) and bool not in self.types or not isinstance(value, self.types):
            expected = "/".join(t.__name__ for t in self.types)
            raise EntryError(f"{where}: expected {expected}, got {type(value).__name__}")
        return value


class Frame(Typed):
    """A pandas DataFrame (pandas imported when one is read: a command that reads none skips its 0.2 s)."""

    def __init__(self):
        super().__init__()

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        import pandas as pd

        self.types = (pd.DataFrame,)
        return super().decode(plain, arrays, where)


class Array(Typed):
    """An ndarray of one dtype and number of dimensions."""

    def __init__(self, dtype: str, ndim: int):
        super().__init__(np.ndarray)
        self.dtype, self.ndim = dtype, ndim

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        value = super().decode(plain, arrays, where)
        if value.dtype.name != self.dtype or value.ndim != self.ndim:
            raise EntryError(f"{where}: expected a {self.ndim}-D {self.dtype} array, got {value.ndim}-D {value.dtype}")
        return value


class Choice(Typed):
    """One of a few strings (or None)."""

    def __init__(self, choices: tuple[str, ...]):
        super().__init__(str, none=True)
        self.choices = choices

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        value = super().decode(plain, arrays, where)
        if value is not None and value not in self.choices:
            raise EntryError(f"{where}: {value[:40]!r} is not one of {self.choices}")
        return value


class Sequence:
    """A tuple whose items are all of one kind (stored as a JSON list)."""

    def __init__(self, item):
        self.item = item

    def encode(self, value: Any, arrays: dict) -> Any:
        return [self.item.encode(v, arrays) for v in value]

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        if not isinstance(plain, list):
            raise EntryError(f"{where}: expected a list, got {type(plain).__name__}")
        return tuple(self.item.decode(v, arrays, f"{where}[{k}]") for k, v in enumerate(plain))


class Named:
    """A mapping of str to one kind, or None (stored as a list of [name, value] pairs)."""

    def __init__(self, item):
        self.item = item

    def encode(self, value: Any, arrays: dict) -> Any:
        return None if value is None else [[str(k), self.item.encode(v, arrays)] for k, v in value.items()]

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        if plain is None:
            return None
        pairs = isinstance(plain, list) and all(isinstance(p, list) and len(p) == 2 for p in plain)
        if not pairs or not all(isinstance(p[0], str) for p in plain):
            raise EntryError(f"{where}: expected a list of [name, value] pairs")
        return {k: self.item.decode(v, arrays, f"{where}[{k[:30]!r}]") for k, v in plain}


class Struct:
    """A frozen dataclass, field by field; ``fixed`` fields are not stored but set when read.

    ``check(value)`` returns what is inconsistent in a decoded value (e.g. shapes that do not
    agree), or None.
    """

    def __init__(self, cls: type, fields: dict, none: bool = False, fixed: Mapping | None = None, check=None):
        self.cls, self.fields, self.none, self.fixed, self.check = cls, fields, none, dict(fixed or {}), check

    def encode(self, value: Any, arrays: dict) -> Any:
        if value is None and self.none:
            return None
        if not isinstance(value, self.cls):
            raise TypeError(f"expected {self.cls.__name__}, got {type(value).__name__}")
        missing = {f.name for f in dataclasses.fields(self.cls)} - set(self.fields) - set(self.fixed)
        if missing:
            raise TypeError(f"{self.cls.__name__} has fields the cache does not store: {sorted(missing)}")
        return {name: kind.encode(getattr(value, name), arrays) for name, kind in self.fields.items()}

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        if plain is None and self.none:
            return None
        if not isinstance(plain, dict) or set(plain) != set(self.fields):
            found = sorted(plain)[:8] if isinstance(plain, dict) else type(plain).__name__
            raise EntryError(f"{where}: expected a {self.cls.__name__} with fields {sorted(self.fields)}, got {found}")
        values = {name: kind.decode(plain[name], arrays, f"{where}.{name}") for name, kind in self.fields.items()}
        try:
            value = self.cls(**values, **self.fixed)
        except (BayesNSIError, TypeError, ValueError, ArithmeticError) as err:
            raise EntryError(f"{where}: invalid {self.cls.__name__} ({err})") from None
        problem = self.check(value) if self.check is not None else None
        if problem:
            raise EntryError(f"{where}: inconsistent {self.cls.__name__}: {problem}")
        return value


FLOAT = Typed(float, int, np.floating, np.integer)
OPTIONAL_FLOAT = Typed(float, int, np.floating, np.integer, none=True)
INT = Typed(int, np.integer)
OPTIONAL_INT = Typed(int, np.integer, none=True)
BOOL = Typed(bool, np.bool_)
STR = Typed(str)
OPTIONAL_STR = Typed(str, none=True)
COMPLEX = Typed(complex, np.complexfloating)
