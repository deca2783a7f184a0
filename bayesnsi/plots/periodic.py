"""Figure of a periodic test: the best linear approximation with its noise and distortion levels.

Pintelon and Schoukens, System Identification (2nd ed., ch. 3-4): the FRF averaged over periods
(and realisations) with the standard deviation due to noise and that due to the nonlinear
distortion beside it. With one realisation the distortion is read at the unexcited lines of a
random-odd multisine (odd lines: odd nonlinearities, even lines: even ones), scaled to FRF units
by the force level of the excited lines.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..io.units import ChannelUnits

__all__ = ["plot_bla"]


def _db(values) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(np.asarray(values, dtype=complex)))


def plot_bla(bla, units=None, channel_names=None):
    """|G_BLA| in dB with its noise and nonlinear-distortion levels, one panel per response channel.

    Parameters
    ----------
    bla : BestLinearApproximation
        From :func:`bayesnsi.nsi.best_linear_approximation`.
    units : ChannelUnits, optional
        Units of the data ("data units" when not given).
    channel_names : sequence of str, optional
        Titles of the panels (default ``response 1..l``).

    Returns
    -------
    matplotlib.figure.Figure
        Lines: |G_BLA| (excited lines), the noise std of G (from the spread over periods), the
        distortion std (spread over realisations minus noise; only with several realisations) and
        the output at the unexcited odd and even lines over the force level (markers).
    """
    units = units or ChannelUnits()
    n_out = bla.frf.shape[1]
    names = list(channel_names) if channel_names is not None else [f"response {k + 1}" for k in range(n_out)]
    fig, axes = plt.subplots(n_out, 1, figsize=(6.4, 2.3 * n_out + 0.6), sharex=True, squeeze=False)
    scale = bla.force_level if np.isfinite(bla.force_level) and bla.force_level > 0 else 1.0
    for k, ax in enumerate(axes[:, 0]):
        ax.plot(bla.freqs_hz, _db(bla.frf[:, k]), color="C0", lw=1.2, label="BLA |G|")
        ax.plot(bla.freqs_hz, _db(np.sqrt(bla.noise_var[:, k])), color="C7", lw=0.8, label="noise std")
        if bla.n_realisations > 1:
            ax.plot(bla.freqs_hz, _db(np.sqrt(bla.distortion_var[:, k])), color="C3", lw=0.8,
                    label="distortion std (realisations)")
        if len(bla.odd_hz):
            ax.plot(bla.odd_hz, _db(np.sqrt(bla.odd_power[:, k]) / scale), "v", color="C3", ms=3,
                    label="unexcited odd lines")
        if len(bla.even_hz):
            ax.plot(bla.even_hz, _db(np.sqrt(bla.even_power[:, k]) / scale), "^", color="C2", ms=3,
                    label="unexcited even lines")
        ax.set_ylabel(f"dB {units.label('frf')}")
        ax.set_title(names[k] if k < len(names) else f"response {k + 1}", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=2)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.tight_layout()
    return fig
