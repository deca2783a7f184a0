"""The sensor noise a model's residual is held against (issue 15), and the lines where the record holds data.

* :func:`sensor_noise_std`, the level per output channel that the noise draws of the adequacy
  check follow (:func:`bayesnsi.run.adequacy.model_checks`; reported as ``noise_std``): the
  period-to-period scatter of a periodic record of at least two whole periods (the force repeats,
  so whatever differs between periods is noise, coloured or not), the sensors' white noise
  integrated by the loader's recipe (accelerations or velocities integrated in time), else white
  noise from high-order differences (:func:`bayesnsi.nsi.white_noise_std`);
* :func:`spectral_lines`, the frequency lines where the record holds data, for the band-by-band
  check of :mod:`bayesnsi.run.residual_bands`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._integrated_noise import acceleration_noise_of

__all__ = ["SENSORS", "SpectralLines", "integrated_in_time", "sensor_noise_std", "spectral_lines"]

_ZERO_LINE = 1e-20  # a line whose power is below this fraction of the channel's largest holds no data


def sensor_noise_std(signals) -> np.ndarray:
    """Noise std of each measured output (module notes): period-to-period scatter, else high-order differences.

    Parameters
    ----------
    signals : Signals
        With ``displacement`` (n_samples, l) and ``period`` (None for a non-periodic record).

    Returns
    -------
    ndarray, shape (l,)
        ``sqrt(Σ_p Σ_t (x_{p,t} - x̄_t)² / (P (n_p - 1)))`` over the ``n_p >= 2`` whole periods of
        ``P`` samples (the first whole periods; a trailing part period is left out); for
        accelerations integrated in time (``signals.acceleration_noise``) the std of their white
        noise integrated by the same recipe (:meth:`bayesnsi._integrated_noise.AccelerationNoise.std`);
        else :func:`bayesnsi.nsi.white_noise_std` of the record.
    """
    from ..nsi import white_noise_std
    from ..nsi.steady import period_scatter_std

    x = np.asarray(signals.displacement, dtype=float).reshape(len(signals.displacement), -1)
    scatter = period_scatter_std(x, getattr(signals, "period", None), getattr(signals, "realisations", 1))
    accelerometers = acceleration_noise_of(signals) if scatter is None and integrated_in_time(signals) else None
    if accelerometers is not None:  # the accelerometers' noise, integrated (edges left out)
        return accelerometers.std(len(x), interior=True)[0]
    return white_noise_std(x) if scatter is None else scatter


SENSORS = {"acceleration": "accelerometers", "velocity": "velocity sensors"}


def integrated_in_time(signals) -> bool:
    """Accelerations integrated in time with their noise and recipe kept (no two whole periods to scatter)."""
    period = getattr(signals, "period", None)
    return acceleration_noise_of(signals) is not None and not (period and signals.n_samples // int(period) >= 2)


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
            from ..nsi.steady import period_blocks

            blocks = period_blocks(r, self.period, self.realisations)
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
    from ..nsi.steady import period_blocks

    x = np.asarray(signals.displacement, dtype=float)
    x = x.reshape(len(x), -1)
    fs, period, realisations = float(signals.fs), getattr(signals, "period", None), int(signals.realisations)
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
    if integrated_in_time(signals):
        recipe = acceleration_noise_of(signals)
        interior, (low, high) = recipe.interior(len(x)), recipe.band_hz
    freqs = np.fft.rfftfreq(len(x[interior]), 1.0 / fs)
    lines = np.flatnonzero((freqs >= low) & (freqs <= high) & (freqs > 0) & (freqs < fs / 2))
    return SpectralLines(freqs[lines], lines, None, 1, interior, 2.0)
