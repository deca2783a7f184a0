"""Self-contained HTML reports: tables and figures embedded, readable offline.

A report is a list of sections; each section has a heading and blocks: text (str),
tables (pandas DataFrame) or figures (matplotlib Figure, embedded as base64 PNG).
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .results import atomic_write_text

__all__ = ["Report", "figure_png"]

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { border-bottom: 2px solid #446; } h2 { color: #335; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.88em; }
th, td { border: 1px solid #bbb; padding: 3px 7px; text-align: right; }
th { background: #eef; } figure { margin: 1em 0; } figcaption { font-size: 0.85em; color: #555; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; font-size: 0.85em; }
.note { color: #555; font-size: 0.9em; }
"""


def figure_png(fig, dpi: int = 100) -> bytes:
    """PNG bytes of a Figure (the Figure is closed)."""
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    plt.close(fig)
    return buffer.getvalue()


@dataclass
class Report:
    """Builder of one HTML report (used by the CLI and workflows only)."""

    title: str
    sections: list[tuple[str, list[Any]]] = field(default_factory=list)

    def section(self, heading: str) -> list:
        """Start a section; returns its block list to append to."""
        blocks: list[Any] = []
        self.sections.append((heading, blocks))
        return blocks

    def to_html(self) -> str:
        """The whole document."""
        parts = [
            "<!DOCTYPE html><html><head><meta charset='utf-8'><meta name='generator' content='bayesnsi'>",
            f"<title>{html.escape(self.title)}</title><style>{_STYLE}</style></head><body>",
            f"<h1>{html.escape(self.title)}</h1>",
        ]
        for heading, blocks in self.sections:
            parts.append(f"<h2>{html.escape(heading)}</h2>")
            for block in blocks:
                parts.append(_render(block))
        parts.append("</body></html>")
        return "\n".join(parts)

    def write(self, path) -> Path:
        """Write atomically."""
        return atomic_write_text(path, self.to_html())


def _render(block) -> str:
    if isinstance(block, str):
        return f"<p>{html.escape(block)}</p>"
    if isinstance(block, tuple) and len(block) == 2 and block[0] == "pre":
        return f"<pre>{html.escape(block[1])}</pre>"
    if hasattr(block, "to_html"):  # pandas DataFrame
        return block.to_html(float_format=lambda v: f"{v:.4g}", na_rep="—", border=0, classes="table")
    if hasattr(block, "savefig"):  # matplotlib Figure
        caption = block.get_label() or ""
        data = base64.b64encode(figure_png(block)).decode("ascii")
        return (
            f"<figure><img alt='{html.escape(caption)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
    raise TypeError(f"cannot render a {type(block).__name__} in a report")
