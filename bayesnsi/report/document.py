"""Self-contained HTML reports: tables and figures embedded, readable offline.

A report is a list of sections, each with a heading, a place (``order``: the answer first, the
versions last) and blocks: text (str), a lead paragraph (``("lead", text)``: green, or
``("lead-bad", text)``: amber, for an answer whose model is not adequate), a warning
(``("warning", text)``), a note (``("note", text)``), preformatted text (``("pre", text)``),
tables (pandas DataFrame, in a container that scrolls sideways rather than widen the page; the
index name heads the index column; ``frame.attrs["wrap_last"]`` lets a last column of long texts
wrap) or figures (matplotlib Figure, embedded as a PNG at :data:`FIGURE_DPI` dpi, never wider than
the page).
"""

from __future__ import annotations

import base64
import html
import math
import numbers
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._text import printable
from ..io.results import atomic_write_text

__all__ = ["FIGURE_DPI", "Report", "clipped_texts", "figure_png", "format_number", "plain_texts"]

FIGURE_DPI = 150
"""Resolution of the figures embedded in a report (dots per inch)."""

_STYLE = """
*, *::before, *::after { box-sizing: border-box; }
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222;
       line-height: 1.45; }
h1 { border-bottom: 2px solid #446; font-size: 1.7em; overflow-wrap: anywhere; }
h2 { color: #335; margin-top: 1.8em; border-bottom: 1px solid #ccd; }
nav { font-size: 0.9em; } nav a { margin-right: 1em; white-space: nowrap; }
.scroll { max-width: 100%; overflow-x: auto; margin: 0.8em 0; }
table { border-collapse: collapse; font-size: 0.88em; }
th, td { border: 1px solid #bbb; padding: 3px 8px; text-align: right; }
td { white-space: nowrap; } table.wrap-last td:last-child { white-space: normal; min-width: 16em; }
thead th { background: #eef; vertical-align: bottom; } tbody th { background: #f7f7fb; text-align: left; }
figure { margin: 1.2em 0; max-width: 100%; } figure img { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 0.85em; color: #555; max-width: 48em; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; max-width: 100%; }
p { max-width: 60em; overflow-wrap: anywhere; }
.lead { font-size: 1.15em; background: #eef5ee; border-left: 5px solid #3a7a3a; padding: 0.6em 0.9em; }
.lead-bad { font-size: 1.15em; background: #fff5e0; border-left: 5px solid #c80; padding: 0.6em 0.9em; }
.warning { background: #fff5e0; border-left: 5px solid #c80; padding: 0.5em 0.9em; }
.note { color: #555; font-size: 0.9em; }
"""


def figure_png(fig, dpi: int = FIGURE_DPI) -> bytes:
    """PNG bytes of a Figure (the Figure is closed).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    dpi : int
        Resolution; :data:`FIGURE_DPI` by default.

    Returns
    -------
    bytes
    """
    from ..plots.rendering import png_bytes

    plain_texts(fig)
    return png_bytes(fig, dpi)


def clipped_texts(fig) -> list[str]:
    """What of a Figure's drawn content (titles, axis and tick labels, legends) sticks out of it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure

    Returns
    -------
    list of str
        For each axes or legend whose drawn extent leaves the figure (by more than 1 px), its title or
        label and the side it leaves by; empty when everything drawn lies inside.
    """
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    out = []
    for artist in [*fig.axes, *fig.legends]:
        box = artist.get_tightbbox(renderer)
        if box is None:
            continue
        sides = [side for side, outside in (("left", box.x0 < frame.x0 - 1), ("bottom", box.y0 < frame.y0 - 1),
                                            ("right", box.x1 > frame.x1 + 1), ("top", box.y1 > frame.y1 + 1))
                 if outside]
        if sides:
            name = artist.get_title() if hasattr(artist, "get_title") else "legend"
            out.append(f"{name or artist.get_label() or type(artist).__name__}: {', '.join(sides)}")
    return out


_MATH_DOLLAR = re.compile(r"(?<!\\)\$")


def plain_texts(fig) -> None:
    """Make every text of ``fig`` show as written: a ``$`` never starts mathtext, control characters escaped.

    Units, channel and candidate names reach titles, axis labels and legends; matplotlib would
    parse ``$x^$`` as (broken) mathtext and fail the whole report, and would warn about the
    missing glyph of an escape character, quoting it raw to the terminal. Tick labels are
    formatted again when the figure is drawn, so the formatter's own mathtext is kept.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Changed in place.
    """
    def has_text(artist) -> bool:
        return callable(getattr(artist, "get_text", None)) and callable(getattr(artist, "set_text", None))

    for artist in fig.findobj(has_text):
        text = artist.get_text()
        if isinstance(text, str) and text:
            plain = _MATH_DOLLAR.sub(r"\\$", printable(text))
            if plain != text:
                artist.set_text(plain)


def format_number(value) -> str:
    """A number as a reader wants it in a table: 4 significant digits, thousands grouped, no 1e-17.

    Parameters
    ----------
    value : object
        A number (other objects are returned as ``str``).

    Returns
    -------
    str
        ``"—"`` for NaN and None, ``"∞"``/``"-∞"`` for infinities; values of 1000 and more with one
        decimal and thousands separators (``13,081.2``: a log evidence keeps its 0.1 nat);
        below 0.001 in scientific notation.
    """
    if value is None:
        return "—"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return str(value)
    if isinstance(value, numbers.Integral):
        return f"{int(value):,}"
    number = float(value)
    if math.isnan(number):
        return "—"
    if math.isinf(number):
        return "∞" if number > 0 else "-∞"
    size = abs(number)
    if size == 0:
        return "0"
    if size >= 1e7:
        return f"{number:.3e}"
    if size >= 1000:
        return f"{number:,.1f}"
    if size < 1e-3:
        return f"{number:.2e}"
    return f"{number:.4g}"


@dataclass
class Report:
    """Builder of one HTML report (the command line and workflows write it).

    Parameters
    ----------
    title : str
    sections : list of (order, heading, blocks)
        Rendered by ``order`` (stable: sections of the same order keep the order they were made in).
    figures : bool
        Whether the builders draw figures (False: tables and text only, ``--no-figures``).
    """

    title: str
    sections: list[tuple[int, str, list[Any]]] = field(default_factory=list)
    figures: bool = True

    def section(self, heading: str, order: int = 50) -> list:
        """Start a section, or continue the one of the same heading and order; returns its block list.

        Parameters
        ----------
        heading : str
        order : int
            Place in the document (lower first); 50 by default.

        Returns
        -------
        list
        """
        for place, name, existing in self.sections:
            if (place, name) == (order, heading):
                return existing
        blocks: list[Any] = []
        self.sections.append((order, heading, blocks))
        return blocks

    def to_html(self) -> str:
        """The whole document.

        Returns
        -------
        str
        """
        ordered = sorted(self.sections, key=lambda item: item[0])
        anchors = [f"s{k}" for k in range(len(ordered))]
        contents = " ".join(f"<a href='#{a}'>{html.escape(h)}</a>" for a, (_, h, _) in zip(anchors, ordered))
        parts = [
            "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><meta name='generator' content='bayesnsi'>",
            "<meta name='viewport' content='width=device-width, initial-scale=1'>",
            f"<title>{html.escape(self.title)}</title><style>{_STYLE}</style></head><body>",
            f"<h1>{html.escape(self.title)}</h1>",
            f"<nav>{contents}</nav>" if len(ordered) > 1 else "",
        ]
        for anchor, (_, heading, blocks) in zip(anchors, ordered):
            parts.append(f"<h2 id='{anchor}'>{html.escape(heading)}</h2>")
            for block in blocks:
                parts.append(_render(block))
        parts.append("</body></html>")
        return "\n".join(parts)

    def write(self, path) -> Path:
        """Write atomically.

        Parameters
        ----------
        path : str or path-like

        Returns
        -------
        Path
        """
        return atomic_write_text(path, self.to_html())


_CLASSES = {"lead": "lead", "lead-bad": "lead-bad", "warning": "warning", "note": "note"}


def _render(block) -> str:
    if isinstance(block, str):
        return f"<p>{html.escape(block)}</p>"
    if isinstance(block, tuple) and len(block) == 2 and block[0] == "pre":
        return f"<pre>{html.escape(block[1])}</pre>"
    if isinstance(block, tuple) and len(block) == 2 and block[0] in _CLASSES:
        return f"<p class='{_CLASSES[block[0]]}'>{html.escape(block[1])}</p>"
    if hasattr(block, "to_html"):  # pandas DataFrame
        classes = "table wrap-last" if getattr(block, "attrs", {}).get("wrap_last") else "table"
        block, index = _index_name_in_header(block)
        table = block.to_html(float_format=format_number, na_rep="—", border=0, classes=classes, escape=True,
                              index=index)
        return f"<div class='scroll'>{table}</div>"
    if hasattr(block, "savefig"):  # matplotlib Figure
        caption = block.get_label() or ""
        width = round(block.get_figwidth() * 96)  # CSS pixels at the figure's size in inches
        data = base64.b64encode(figure_png(block)).decode("ascii")
        return (
            f"<figure><img alt='{html.escape(caption, quote=True)}' width='{width}' "
            f"src='data:image/png;base64,{data}'><figcaption>{html.escape(caption)}</figcaption></figure>"
        )
    raise TypeError(f"cannot render a {type(block).__name__} in a report")


def _index_name_in_header(frame):
    """The frame with its index names in the header row (pandas gives them a row of their own), and whether
    to render the index: a single named index heads its own column; a multi-level index becomes columns."""
    if frame.columns.nlevels != 1 or not any(frame.index.names):
        return frame, True
    if frame.index.nlevels == 1:
        moved = frame.copy()
        moved.columns.name, moved.index.name = frame.index.name, None
        return moved, True
    return frame.reset_index(), False
