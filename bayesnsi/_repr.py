"""Compact ``repr`` of result objects: a few scalars and the shapes of arrays, never the arrays."""

from __future__ import annotations

__all__ = ["compact_repr"]

_MAX_TEXT = 60


def compact_repr(obj, **fields) -> str:
    """``Name(field=value, ...)`` with arrays shown by shape and long texts cut.

    Parameters
    ----------
    obj : object
        The object whose class names the repr.
    **fields
        What to show, in order.

    Returns
    -------
    str
    """
    parts = ", ".join(f"{name}={_short(value)}" for name, value in fields.items())
    return f"{type(obj).__name__}({parts})"


def _short(value) -> str:
    shape = getattr(value, "shape", None)
    if shape is not None and not isinstance(value, (int, float)) and len(shape) > 0:
        return f"<array {'x'.join(str(s) for s in shape)}>"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (tuple, list)) and len(value) > 6:
        return f"<{len(value)} items>"
    text = repr(value)
    return text if len(text) <= _MAX_TEXT else text[: _MAX_TEXT - 3] + "..."
