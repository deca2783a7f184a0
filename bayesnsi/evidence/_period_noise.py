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

__all__ = ["PeriodNoise", "period_noise"]


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
    from ..nsi.steady import period_deviations

    deviations = period_deviations(record, period, realisations)
    return None if deviations is None else PeriodNoise(deviations, realisations)
