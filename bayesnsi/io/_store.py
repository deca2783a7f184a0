"""A file format for results that cannot run code: JSON for the structure, ``.npy`` for arrays.

An entry is one uncompressed ZIP file (a valid ``.npz``): a member ``entry.json`` holding the
structure and every scalar, and members ``a0.npy``, ``a1.npy``, ... holding the arrays, which the
JSON names (``{"$array": "a0"}``). Reading parses only JSON and array headers, so nothing in a
file can name a class or a function; the only things a file can make the reader allocate are
bounded before they are allocated:

- the file is refused when larger than :func:`bayesnsi._limits.max_memory_bytes`, before it is
  read (it is read once, into memory, so it cannot change while it is checked);
- ``entry.json`` is refused when larger than :data:`MAX_JSON_BYTES` or nested deeper than
  :data:`MAX_DEPTH`;
- every array header is checked before its data are read: dtype float64, complex128 or int64
  (object arrays are also refused by ``numpy.load(..., allow_pickle=False)``), C order, and a
  shape whose size is exactly the bytes the member holds (so the arrays together hold no more
  than the file: reading allocates at most about twice the file's size, plus the JSON values).

Values are encoded losslessly (:func:`encode_value`): floats as JSON numbers (Python writes the
shortest text that reads back to the same float; NaN and ±Infinity as ``NaN``/``Infinity``),
arrays bit for bit, tuples, complex numbers, numpy scalars, non-string dict keys and pandas
data frames with a tag (an object whose only keys start with ``$``).
"""

from __future__ import annotations

import io
import json
import re
import zipfile
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError

__all__ = ["ALLOWED_DTYPES", "MAX_DEPTH", "MAX_JSON_BYTES", "EntryError", "decode_value", "encode_value",
           "read_container", "write_container"]

ALLOWED_DTYPES = ("float64", "complex128", "int64")
"""The only array dtypes an entry may hold."""

MAX_JSON_BYTES = 8 * 2**20
"""Largest ``entry.json`` read (8 MiB; results keep their arrays in ``.npy`` members)."""

MAX_DEPTH = 48
"""Deepest nesting of JSON containers accepted."""

_JSON_MEMBER = "entry.json"
_ARRAY_MEMBER = re.compile(r"a(0|[1-9][0-9]{0,6})\.npy")
_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


class EntryError(InputDataError):
    """A stored entry is not a valid entry of this format (the message says what is wrong)."""


# ---------------------------------------------------------------------------------------------
# container: entry.json + a<k>.npy members in one uncompressed ZIP


def write_container(fh, document: Any, arrays: Mapping[str, np.ndarray]) -> None:
    """Write ``document`` (JSON values) and ``arrays`` (from :func:`encode_value`) to ``fh``.

    Parameters
    ----------
    fh : binary file object
        Open for writing and seekable (e.g. from :func:`bayesnsi.io.results.atomic_open`).
    document : object
        JSON-ready values (NaN and ±Infinity allowed).
    arrays : mapping of str to ndarray
        Member name (``a<k>``) -> array of an allowed dtype.
    """
    text = json.dumps(document, separators=(",", ":"), ensure_ascii=False)
    with zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_STORED) as archive:
        archive.writestr(_JSON_MEMBER, text.encode("utf-8"))
        for name, array in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.ascontiguousarray(array), allow_pickle=False)


def read_container(data: bytes, what: str) -> tuple[Any, dict[str, np.ndarray]]:
    """Parse an entry written by :func:`write_container`, checking every size before reading.

    Parameters
    ----------
    data : bytes
        The whole file (its size was checked against the memory limit by the caller).
    what : str
        Name of the entry, for messages.

    Returns
    -------
    document : object
        The decoded ``entry.json``.
    arrays : dict of str to ndarray
        Member name (``a<k>``) -> array.

    Raises
    ------
    EntryError
        If the file is not such an entry, or a member is too large, of another dtype or
        inconsistent with its header.
    """
    if not data.startswith(b"PK\x03\x04"):
        raise EntryError(f"{what} is not an entry archive (it does not start with a ZIP header)")
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        members = archive.infolist()
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, ValueError, EOFError) as err:
        raise EntryError(f"{what} is not an entry archive ({err})") from None
    names = [m.filename for m in members]
    if _JSON_MEMBER not in names or len(set(names)) != len(names):
        raise EntryError(f"{what} has no single {_JSON_MEMBER} member")
    total = 0
    for member in members:
        if member.compress_type != zipfile.ZIP_STORED or member.flag_bits & 0x1:
            raise EntryError(f"{what}: member {member.filename!r} is compressed or encrypted")
        if member.filename != _JSON_MEMBER and not _ARRAY_MEMBER.fullmatch(member.filename):
            raise EntryError(f"{what}: unexpected member {member.filename[:40]!r}")
        total += member.file_size
    if total > len(data):
        raise EntryError(f"{what}: members claim {total} bytes, more than the {len(data)}-byte file holds")
    document = _read_json(archive, members[names.index(_JSON_MEMBER)], what)
    for member in members:
        if member.filename != _JSON_MEMBER:
            _check_array_header(archive, member, what)
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            arrays = {name[: -len(".npy")]: npz[name[: -len(".npy")]] for name in names if name != _JSON_MEMBER}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError) as err:
        raise EntryError(f"{what}: unreadable array ({err})") from None
    return document, arrays


def _read_json(archive: zipfile.ZipFile, member: zipfile.ZipInfo, what: str) -> Any:
    if member.file_size > MAX_JSON_BYTES:
        raise EntryError(f"{what}: {_JSON_MEMBER} claims {member.file_size} bytes, above {MAX_JSON_BYTES}")
    try:
        with archive.open(member) as fh:
            raw = fh.read(MAX_JSON_BYTES + 1)
        text = raw.decode("utf-8")
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as err:
        raise EntryError(f"{what}: unreadable {_JSON_MEMBER} ({err})") from None
    if len(raw) > MAX_JSON_BYTES:
        raise EntryError(f"{what}: {_JSON_MEMBER} is above {MAX_JSON_BYTES} bytes")
    _check_nesting(text, what)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as err:
        raise EntryError(f"{what}: {_JSON_MEMBER} is not valid JSON ({err})") from None


def _check_nesting(text: str, what: str) -> None:
    """Refuse JSON nested deeper than MAX_DEPTH (counting brackets outside strings)."""
    depth = 0
    for token in re.finditer(r'"(?:[^"\\]|\\.)*"|[\[\]{}]', text):
        char = token.group()
        if char in "[{":
            depth += 1
            if depth > MAX_DEPTH:
                raise EntryError(f"{what}: {_JSON_MEMBER} is nested deeper than {MAX_DEPTH}")
        elif char in "]}":
            depth -= 1


def _check_array_header(archive: zipfile.ZipFile, member: zipfile.ZipInfo, what: str) -> None:
    """Check dtype, order and size of one ``.npy`` member from its header, before reading data."""
    label = f"{what}: array {member.filename!r}"
    try:
        with archive.open(member) as fh:
            version = np.lib.format.read_magic(fh)
            if version not in _HEADER_READERS:
                raise EntryError(f"{label} has .npy format version {version}, expected 1.0 or 2.0")
            shape, fortran, dtype = _HEADER_READERS[version](fh, max_header_size=10_000)
            offset = fh.tell()
    except EntryError:
        raise
    except (ValueError, OSError, EOFError, SyntaxError, TypeError, zipfile.BadZipFile) as err:
        raise EntryError(f"{label} has an unreadable header ({err})") from None
    if dtype.hasobject or dtype.str.lstrip("<=|") not in ("f8", "c16", "i8") or dtype.byteorder == ">":
        raise EntryError(f"{label} has dtype {dtype}; allowed: {', '.join(ALLOWED_DTYPES)} (little-endian)")
    if fortran:
        raise EntryError(f"{label} is in Fortran order; entries hold C-ordered arrays")
    if len(shape) > 32 or any(not isinstance(n, int) or n < 0 for n in shape):
        raise EntryError(f"{label} has an invalid shape {shape!r}")
    n_bytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if n_bytes != member.file_size - offset:
        raise EntryError(f"{label} claims {n_bytes} bytes of data but holds {member.file_size - offset}")
    check_allocation(n_bytes, label)


# ---------------------------------------------------------------------------------------------
# lossless JSON encoding of plain values (arrays go to members)


def encode_value(value: Any, arrays: dict[str, np.ndarray]) -> Any:
    """Encode ``value`` as JSON values, moving arrays (and numpy scalars) into ``arrays``.

    Parameters
    ----------
    value : object
        None, bool, int, float, complex, str, tuple, list, mapping, ndarray or numpy scalar of
        an allowed dtype, or a pandas DataFrame of such columns; nested freely.
    arrays : dict
        Filled with ``"a<k>" -> array`` for every array met.

    Returns
    -------
    object
        JSON values; :func:`decode_value` rebuilds ``value`` exactly.

    Raises
    ------
    TypeError
        For any other type (naming it).
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (int, float)) and type(value) in (int, float):
        return value
    if isinstance(value, complex) and type(value) is complex:
        return {"$complex": [value.real, value.imag]}
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (np.ndarray, np.generic)):
        array = np.asarray(value)
        if array.dtype.name not in ALLOWED_DTYPES:
            raise TypeError(f"cannot store an array of dtype {array.dtype} (allowed: {', '.join(ALLOWED_DTYPES)})")
        name = f"a{len(arrays)}"
        arrays[name] = array.astype(array.dtype.newbyteorder("<"), copy=False)
        return {"$array" if isinstance(value, np.ndarray) else "$scalar": name}
    if isinstance(value, tuple):
        return {"$tuple": [encode_value(v, arrays) for v in value]}
    if isinstance(value, list):
        return [encode_value(v, arrays) for v in value]
    if isinstance(value, Mapping):
        if all(isinstance(k, str) and not k.startswith("$") for k in value):
            return {k: encode_value(v, arrays) for k, v in value.items()}
        return {"$dict": [[encode_value(k, arrays), encode_value(v, arrays)] for k, v in value.items()]}
    if type(value).__name__ == "DataFrame" and type(value).__module__.startswith("pandas"):
        return {"$frame": {
            "index": encode_value(list(value.index), arrays),
            "index_name": encode_value(value.index.name, arrays),
            "columns": encode_value(list(value.columns), arrays),
            "data": [encode_value(value[c].to_numpy(), arrays) for c in value.columns],
        }}
    raise TypeError(f"cannot store a value of type {type(value).__name__}")


def decode_value(plain: Any, arrays: Mapping[str, np.ndarray], where: str = "entry") -> Any:
    """Inverse of :func:`encode_value`.

    Parameters
    ----------
    plain : object
        JSON values from an entry.
    arrays : mapping of str to ndarray
        The entry's arrays.
    where : str
        Position in the entry, for messages.

    Returns
    -------
    object

    Raises
    ------
    EntryError
        For a malformed tag or a reference to a missing array.
    """
    if plain is None or isinstance(plain, (bool, int, float, str)):
        return plain
    if isinstance(plain, list):
        return [decode_value(v, arrays, f"{where}[{k}]") for k, v in enumerate(plain)]
    if not isinstance(plain, dict):
        raise EntryError(f"{where}: unexpected JSON value {type(plain).__name__}")
    tags = [k for k in plain if k.startswith("$")]
    if not tags:
        return {k: decode_value(v, arrays, f"{where}.{k}") for k, v in plain.items()}
    if len(plain) != 1:
        raise EntryError(f"{where}: a tagged value must have exactly one key, got {sorted(plain)[:5]}")
    tag, body = tags[0], plain[tags[0]]
    if tag in ("$array", "$scalar"):
        if not isinstance(body, str) or body not in arrays:
            raise EntryError(f"{where}: reference to a missing array {str(body)[:20]!r}")
        if tag == "$array":
            return arrays[body]
        return arrays[body][()] if arrays[body].ndim == 0 else _bad(where, tag)
    if tag == "$complex" and isinstance(body, list) and len(body) == 2 and all(_is_real(v) for v in body):
        return complex(body[0], body[1])
    if tag == "$tuple" and isinstance(body, list):
        return tuple(decode_value(v, arrays, f"{where}[{k}]") for k, v in enumerate(body))
    if tag == "$dict" and isinstance(body, list) and all(isinstance(p, list) and len(p) == 2 for p in body):
        pairs = [(decode_value(k, arrays, where), decode_value(v, arrays, where)) for k, v in body]
        try:
            return dict(pairs)
        except TypeError:
            raise EntryError(f"{where}: unhashable dict key") from None
    if tag == "$frame" and isinstance(body, dict) and set(body) == {"index", "index_name", "columns", "data"}:
        return _decode_frame(body, arrays, where)
    return _bad(where, tag)


def _decode_frame(body: dict, arrays: Mapping[str, np.ndarray], where: str):
    import pandas as pd

    index, columns = decode_value(body["index"], arrays, where), decode_value(body["columns"], arrays, where)
    data = decode_value(body["data"], arrays, where)
    name = decode_value(body["index_name"], arrays, where)
    if not (isinstance(index, list) and isinstance(columns, list) and isinstance(data, list)):
        _bad(where, "$frame")
    if len(data) != len(columns) or any(not isinstance(d, np.ndarray) or d.shape != (len(index),) for d in data):
        raise EntryError(f"{where}: data frame columns do not match its index")
    if not all(isinstance(v, (str, int, float)) for v in index + columns) or not isinstance(name, (str, type(None))):
        raise EntryError(f"{where}: data frame labels must be strings or numbers")
    frame = pd.DataFrame(dict(zip(range(len(columns)), data)), index=pd.Index(index, name=name))
    frame.columns = pd.Index(columns)
    return frame


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _bad(where: str, tag: str):
    raise EntryError(f"{where}: malformed {tag} value")
