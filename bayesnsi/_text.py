"""User-controlled text made safe to show: no control characters on a terminal, no undecodable paths.

File names, column names, units, lock fields and the messages built from them reach the
terminal; a name holding an escape sequence (``\\x1b]0;...``), a carriage return or a bidi
override could rewrite what the user sees. :func:`printable` writes every such character as
a visible escape (``\\x1b``, ``\\u202e``). :func:`check_path_text` refuses, when a run starts, a
path that is not valid text (a byte that is not UTF-8 in a file name), which would otherwise
fail only when the results are written.
"""

from __future__ import annotations

import os
import unicodedata

from .exceptions import ConfigError

__all__ = ["check_path_text", "printable"]

_KEPT = frozenset("\n\t")


def printable(text: object, keep_newlines: bool = True) -> str:
    """``str(text)`` with control, format (bidi) and lone surrogate characters as visible escapes.

    Parameters
    ----------
    text : object
        Anything; converted with ``str``.
    keep_newlines : bool
        Keep newlines and tabs as they are (else they are escaped too).

    Returns
    -------
    str
        Safe to print on a terminal.

    Examples
    --------
    >>> printable("data\\x1b[2J.csv")
    'data\\\\x1b[2J.csv'
    """
    text = str(text)
    if text.isprintable():
        return text
    out = []
    for char in text:
        if char.isprintable() or (keep_newlines and char in _KEPT) or char == " ":
            out.append(char)
            continue
        category = unicodedata.category(char)
        if category in ("Zs",):
            out.append(char)
        else:
            code = ord(char)
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}")
    return "".join(out)


def check_path_text(path: str | os.PathLike, what: str) -> None:
    """Refuse a path that is not valid UTF-8 text (or holds a NUL), before any work is done.

    Parameters
    ----------
    path : str or path-like
        A path as given by the user (bytes decoded with ``surrogateescape``).
    what : str
        What the path is, for the message (e.g. ``"config file"``).

    Raises
    ------
    ConfigError
        Naming the path with its bad bytes escaped.
    """
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise ConfigError(
            f"the {what} {printable(text)!r} holds bytes that are not UTF-8 text; rename it with letters, digits "
            "and punctuation (results.json and the report record the path as text)"
        ) from None
    if "\x00" in text:
        raise ConfigError(f"the {what} {printable(text)!r} holds a NUL character")
