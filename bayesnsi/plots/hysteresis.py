"""The restoring-force loop of a Bouc-Wen term (docs/method.md §12)."""

from __future__ import annotations

import matplotlib.pyplot as plt

from ..curves import hysteresis_loop
from ..io.units import ChannelUnits

__all__ = ["plot_hysteresis_loop"]


def plot_hysteresis_loop(step, signals, units=None, cycles: float = 4.0):
    """Force against displacement of a Bouc-Wen term: its path on the record and its steady loop.

    Draws λ z along the measured displacement over a window of about ``cycles`` periods of its
    dominant frequency (grey), and the loop of a sine at the measured amplitude (√2 × rms) in
    periodic steady state (black), annotated with the hysteretic stiffness, the yield and the energy
    the loop dissipates per cycle (:func:`bayesnsi.curves.hysteresis_loop`).

    Parameters
    ----------
    step : object with ``term`` and ``coefficient`` (or ``value``)
        A ``boucwen`` term and its coefficient λ (an accepted loop step, or a coefficient of a result).
    signals : Signals
        The measured signals.
    units : ChannelUnits, optional
        Units of the data (:func:`bayesnsi.io.units.data_units`); "data units" when not given.
    cycles : float
        Periods of the dominant frequency in the window of the measured path.

    Returns
    -------
    matplotlib.figure.Figure
    """
    units = units or ChannelUnits()
    curve = hysteresis_loop(step, signals, cycles)
    reading = curve.reading
    fig, ax = plt.subplots(figsize=(5.6, 4.2), layout="constrained")
    ax.plot(curve.displacement, curve.force, lw=0.8, color="0.6", label="on the record")
    ax.plot(curve.loop_displacement, curve.loop_force, lw=1.6, color="k",
            label=f"steady loop, amplitude {reading.amplitude:.3g}")
    ax.set_xlabel(f"{curve.displacement_label} {units.label('displacement')}")
    ax.set_ylabel(f"hysteretic force λ z {units.label('force')}")
    yielding = ("no yield (the loading branch hardens)" if reading.yield_displacement is None
                else f"yields at {reading.yield_displacement:.3g} {units.label('displacement')}, "
                f"{reading.yield_force:.3g} {units.label('force')}")
    ax.text(0.02, 0.98, f"hysteretic stiffness λ = {reading.stiffness:.4g}\n{yielding}\n"
            f"dissipated per cycle {reading.loop_area:.3g} {units.label('force')}·{units.label('displacement')}",
            transform=ax.transAxes,
            va="top", fontsize=8)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(curve.title, fontsize=10)
    return fig
