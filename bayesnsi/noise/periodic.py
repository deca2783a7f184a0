"""Replicate noise of a periodic record drawn from its own period-to-period scatter.

On a record of whole repeated periods the noise is what changes from one period to the next.
Its deviations from the period mean, d_j = y_j - ȳ (j = 1..n periods), carry the noise's
spectrum and its correlation between channels exactly, whatever the processing before (an
accelerometer integrated line by line to a displacement holds noise in the integration band
only, where high-order differences see almost none: on a simulated ground vibration test
:func:`bayesnsi.nsi.white_noise_std` gave 8e-8 m against a period scatter of 1.6e-4 m).
A replicate period is ``e* = Σ_j g_j d_j / sqrt(n - 1)`` with fresh standard normal g_j: given the
data it is Gaussian with the sample covariance of the deviations (an unbiased estimate of the
noise covariance, as a process over the period), new for every period of every replicate.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PeriodNoise", "period_blocks", "period_deviations", "period_noise", "period_scatter_std"]


class PeriodNoise:
    """Period-to-period deviations of a record, and draws of noise with their covariance.

    Parameters
    ----------
    deviations : ndarray, shape (n_periods, period, n_channels)
        ``y_j - ȳ`` per whole period (``ȳ`` the mean of the period's realisation).
    realisations : int
        Equal-length realisations the deviations come from, in order (``n_periods / realisations``
        periods each): each realisation's noise is drawn from its own deviations.
    """

    def __init__(self, deviations: np.ndarray, realisations: int = 1) -> None:
        self.deviations = np.asarray(deviations, dtype=float)
        self.realisations = max(int(realisations), 1)

    @property
    def std(self) -> np.ndarray:
        """Noise std per channel, ``sqrt(Σ_j Σ_t d_j(t)² / (P R (n - 1)))`` (n periods in each of R realisations).

        Returns
        -------
        ndarray, shape (n_channels,)
        """
        n, period = self.deviations.shape[:2]
        return np.sqrt(np.sum(self.deviations**2, axis=(0, 1)) / (period * (n - self.realisations)))

    def draw(self, n_samples: int, rng: np.random.Generator) -> np.ndarray:
        """Noise for ``n_samples`` samples, a new random combination of the deviations per period.

        With several realisations the record is cut into as many equal parts, each drawn from the
        deviations of its own realisation.

        Parameters
        ----------
        n_samples : int
            Length of the record to perturb (a trailing part period takes the start of a drawn one).
        rng : numpy.random.Generator
            Source of the combination weights.

        Returns
        -------
        ndarray, shape (n_samples, n_channels)
        """
        n_all, period, channels = self.deviations.shape
        n = n_all // self.realisations
        length = int(n_samples) // self.realisations
        parts = []
        for r in range(self.realisations):
            size = length if r < self.realisations - 1 else int(n_samples) - r * length
            n_draw = -(-size // period)
            weights = rng.standard_normal((n_draw, n)) / np.sqrt(n - 1)
            own = self.deviations[r * n : (r + 1) * n]
            parts.append(np.einsum("kj,jtc->ktc", weights, own).reshape(n_draw * period, channels)[:size])
        return np.concatenate(parts)


def period_noise(record, period, realisations: int = 1) -> PeriodNoise | None:
    """The period-to-period deviations of ``record``, or None when it is not periodic.

    Parameters
    ----------
    record : array_like, shape (n_samples, n_channels)
        Measured responses (e.g. displacements and velocities side by side).
    period : int or None
        Samples per period (``Signals.period``).
    realisations : int
        Equal-length realisations one after the other (``Signals.realisations``).

    Returns
    -------
    PeriodNoise or None
        None without a period or with fewer than two whole periods per realisation; else the
        deviations of each realisation's whole periods from its own mean (a trailing part period
        is left out).
    """
    deviations = period_deviations(record, period, realisations)
    return None if deviations is None else PeriodNoise(deviations, realisations)


def period_blocks(signal, period, realisations: int = 1) -> np.ndarray | None:
    """The whole periods of each realisation, in order, or None without two of them per realisation.

    Parameters
    ----------
    signal : array_like, shape (n_samples, n_channels)
        A periodic record (a trailing part period is left out).
    period : int or None
        Samples per period.
    realisations : int
        Equal-length realisations the record holds one after the other (``Signals.realisations``).

    Returns
    -------
    ndarray, shape (n_periods, period, n_channels) or None
        The periods of all realisations in order (``n_periods / realisations`` each).
    """
    if not period:
        return None
    y = np.asarray(signal, dtype=float)
    y = y.reshape(len(y), -1)
    period, realisations = int(period), max(int(realisations), 1)
    n = len(y) // realisations // period
    if n < 2:
        return None
    length = len(y) // realisations
    return np.concatenate([y[r * length : r * length + n * period].reshape(n, period, y.shape[1])
                           for r in range(realisations)])


def period_deviations(signal, period, realisations: int = 1) -> np.ndarray | None:
    """Deviations ``y_p - ȳ`` of each whole period from its realisation's period mean, or None without two periods.

    Parameters
    ----------
    signal : array_like, shape (n_samples, n_channels)
        A periodic record (a trailing part period is left out).
    period : int or None
        Samples per period.
    realisations : int
        Equal-length realisations the record holds one after the other (``Signals.realisations``):
        each period deviates from the mean of its own realisation (new phases: another mean).

    Returns
    -------
    ndarray, shape (n_periods, period, n_channels) or None
        The periods of all realisations in order (``n_periods / realisations`` each).
    """
    blocks = period_blocks(signal, period, realisations)
    if blocks is None:
        return None
    per_realisation = blocks.reshape(max(int(realisations), 1), -1, *blocks.shape[1:])
    return (per_realisation - per_realisation.mean(axis=1, keepdims=True)).reshape(blocks.shape)


def period_scatter_std(signal, period, realisations: int = 1) -> np.ndarray | None:
    """Noise std per channel from the scatter between whole periods, or None without two of them.

    Parameters
    ----------
    signal : array_like, shape (n_samples, n_channels)
        A periodic record (a trailing part period is left out).
    period : int or None
        Samples per period.
    realisations : int
        Realisations in the record (:func:`period_deviations`); the scatter is pooled over them.

    Returns
    -------
    ndarray, shape (n_channels,)
        ``sqrt(Σ_p Σ_t (y_{p,t} - ȳ_t)² / (P R (n - 1)))`` over the n whole periods of each of the R
        realisations.
    """
    deviations = period_deviations(signal, period, realisations)
    if deviations is None:
        return None
    n, samples = deviations.shape[:2]
    r = max(int(realisations), 1)
    return np.sqrt(np.sum(deviations**2, axis=(0, 1)) / (samples * (n - r)))
