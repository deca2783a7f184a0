"""The frequency lines where a record holds data, on which a residual is compared with the noise.

:func:`spectral_lines` gives the band-by-band residual check (:mod:`bayesnsi.checks.residual_bands`)
the lines to read: a period's DFT lines on whole periods, else the record's DFT lines inside an
integration band (the record's ends left out), else every line.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .integrated import acceleration_noise_of
from .periodic import period_blocks

__all__ = ["SpectralLines", "spectral_lines"]

_ZERO_LINE = 1e-20  # a line whose power is below this fraction of the channel's largest holds no data


@dataclass(frozen=True)
class SpectralLines:
    """The frequency lines on which a residual is compared with the noise, and how to take its power there.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_lines,)
        Frequencies of the lines compared [Hz].
    lines : ndarray of int, shape (n_lines,)
        Their indices in the DFT of a period (``period`` set) or of the compared part of the record.
    period, realisations : int or None, int
        The periodic layout, or None for a DFT of the whole record.
    interior : slice
        The samples compared (the ends of a record integrated in time are left out).
    dof_per_line : float
        Degrees of freedom of a residual's power on one line: 2 per DFT, times the periods averaged.
    """

    frequencies_hz: np.ndarray
    lines: np.ndarray
    period: int | None
    realisations: int
    interior: slice
    dof_per_line: float

    def within(self, band_hz) -> SpectralLines:
        """The lines inside ``band_hz`` (e.g. the band a frequency-domain identification fitted).

        Parameters
        ----------
        band_hz : (float, float)
            Lower and upper frequency [Hz].

        Returns
        -------
        SpectralLines
        """
        keep = (self.frequencies_hz >= band_hz[0]) & (self.frequencies_hz <= band_hz[1])
        return replace(self, frequencies_hz=self.frequencies_hz[keep], lines=self.lines[keep])

    def power(self, signal) -> np.ndarray:
        """Power of ``signal`` on the lines, ``|DFT|² / n`` (averaged over the periods of a periodic layout).

        Parameters
        ----------
        signal : array_like, shape (n_samples, l)
            A residual (or any record) at the data's samples.

        Returns
        -------
        ndarray, shape (n_lines, l)
        """
        r = np.asarray(signal, dtype=float)
        r = r.reshape(len(r), -1)[self.interior]
        if self.period is not None:
            blocks = period_blocks(r, self.period, self.realisations)
            if blocks is None:
                raise ValueError("the lines of a periodic layout need two or more whole periods")
            return np.mean(np.abs(np.fft.rfft(blocks, axis=1)[:, self.lines]) ** 2, axis=0) / self.period
        return np.abs(np.fft.rfft(r, axis=0)[self.lines]) ** 2 / len(r)


def spectral_lines(signals) -> SpectralLines:
    """The lines where the record holds data (module notes).

    Every line between 0 and the Nyquist frequency, except: on two or more whole periods, the DFT
    lines of a period that the data do not hold (set to zero by an integration line by line,
    outside its band); for responses integrated in time, the lines outside the integration band and
    the samples at the record's ends (:meth:`AccelerationNoise.interior`).

    Parameters
    ----------
    signals : Signals
        The estimation data (``period``, ``realisations`` and ``acceleration_noise`` read).

    Returns
    -------
    SpectralLines
    """
    x = np.asarray(signals.displacement, dtype=float)
    x = x.reshape(len(x), -1)
    fs, period, realisations = float(signals.fs), signals.period, int(signals.realisations)
    blocks = period_blocks(x, period, realisations)
    if blocks is not None:  # two or more whole periods
        period = int(period)
        n_periods = len(blocks) // realisations
        # each realisation's whole record, whose DFT line k n_p is line k of a period: nil outside the band of
        # an integration line by line (a period's own DFT leaks the deviations into every line)
        records = blocks.reshape(realisations, n_periods * period, x.shape[1])
        power = np.sum(np.abs(np.fft.rfft(records, axis=1)[:, ::n_periods]) ** 2, axis=0)
        freqs = np.fft.rfftfreq(period, 1.0 / fs)
        keep = (freqs > 0) & (freqs < fs / 2) & np.all(power > _ZERO_LINE * power.max(axis=0), axis=1)
        lines = np.flatnonzero(keep)
        return SpectralLines(freqs[lines], lines, period, realisations, slice(None), 2.0 * len(blocks))
    interior, low, high = slice(None), 0.0, fs / 2
    recipe = acceleration_noise_of(signals)
    if recipe is not None:  # integrated in time (no two whole periods: those returned above)
        interior, (low, high) = recipe.interior(len(x)), recipe.band_hz
    freqs = np.fft.rfftfreq(len(x[interior]), 1.0 / fs)
    lines = np.flatnonzero((freqs >= low) & (freqs <= high) & (freqs > 0) & (freqs < fs / 2))
    return SpectralLines(freqs[lines], lines, None, 1, interior, 2.0)
