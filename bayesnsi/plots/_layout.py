"""Fixed margins fitted to the texts around one axes: constrained layout's result at a fraction of its cost.

Constrained layout measures every artist of every axes twice before a figure is drawn (a third of
the drawing time of a one-panel report figure); the texts that set the margins - tick labels, axis
labels, the title, a legend beside the axes - are measured here once, from their strings and fonts.

Titles of the report's figures are set with ``y=1.0`` where no text can sit above the axes (no tick
labels on top, no offset text of a linear axis beside the title, :func:`title_height`): matplotlib
then places them at the top without measuring the y axis's ticks once more for each title (8 % of
the drawing time).
"""

from __future__ import annotations

import matplotlib as mpl
from matplotlib.font_manager import FontProperties
from matplotlib.ticker import ScalarFormatter

__all__ = ["fit_margins", "title_height"]

_EDGE = 4.0  # free border around the drawn texts [pt]


def fit_margins(ax, legend=None) -> None:
    """Place ``ax`` in its figure so that its labels, title and an outside legend fit, with fixed margins.

    Call when the axes are complete (limits, ticks, labels). The figure must hold ``ax`` alone
    and no layout engine.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    legend : matplotlib.legend.Legend, optional
        A legend placed right of the axes (``bbox_to_anchor`` beyond x = 1), whose width the right
        margin makes room for.
    """
    fig = ax.figure
    rc = mpl.rcParams
    renderer = fig.canvas.get_renderer()
    to_points = 72.0 / fig.dpi

    def ticks(axis, side: str) -> tuple[float, float, float]:  # widest and highest tick label, tick + pad [pt]
        name = axis.axis_name
        params = axis.get_tick_params(which="major")
        marks = (params.get(side, True) and params.get("length", rc[f"{name}tick.major.size"])) or 0.0
        room = marks + params.get("pad", rc[f"{name}tick.major.pad"])
        if not params.get(f"label{side}", True):
            return 0.0, 0.0, marks
        labels = axis.major.formatter.format_ticks(list(axis.get_majorticklocs()))
        prop = FontProperties(size=params.get("labelsize", rc[f"{name}tick.labelsize"]))
        sizes = [renderer.get_text_width_height_descent(s, prop, ismath=False) for s in labels if s]
        return (max((w for w, _, _ in sizes), default=0.0) * to_points,
                max((h for _, h, _ in sizes), default=0.0) * to_points, room)

    def line(text) -> float:  # height [pt] of a one-line label or title ("lp" sets it, as for matplotlib), or 0
        if not text.get_text():
            return 0.0
        prop = text.get_fontproperties()
        return max(renderer.get_text_width_height_descent(s, prop, ismath=False)[1]
                   for s in (text.get_text(), "lp")) * to_points

    y_width, _, y_room = ticks(ax.yaxis, "left")
    x_width, x_height, x_room = ticks(ax.xaxis, "bottom")
    left = _EDGE + line(ax.yaxis.label) + ax.yaxis.labelpad + y_width + y_room
    bottom = _EDGE + line(ax.xaxis.label) + ax.xaxis.labelpad + x_height + x_room
    top = _EDGE + line(ax.title) + rc["axes.titlepad"]
    width, height = (size * 72.0 for size in fig.get_size_inches())
    right = _EDGE + x_width / 2  # the last tick label may centre on the right edge
    if legend is not None:  # beside the axes, 1 % of their width away
        right = max(right, _EDGE + legend.get_window_extent(renderer).width * to_points + 0.01 * width)
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height, top=1 - top / height)


def title_height(ax) -> dict:
    """``{"y": 1.0}`` for ``Axes.set_title`` when nothing is drawn above ``ax`` (no offset text such as ``1e9``
    on its y axis), else ``{}`` (matplotlib then lifts the title over it).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        With its data drawn (the offset depends on the limits).

    Returns
    -------
    dict
    """
    formatter = ax.yaxis.get_major_formatter()
    if isinstance(formatter, ScalarFormatter):
        formatter.set_locs(ax.yaxis.get_majorticklocs())
        if formatter.get_offset():
            return {}
    return {"y": 1.0}
