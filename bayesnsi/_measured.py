"""Errors in the measured quantity (docs/method.md §9).

NSI works on displacements; a test that measures accelerations integrates them (``[data]
integrate``) and :class:`~bayesnsi.signals.Signals` keeps only the displacement and velocity, with
``Signals.measured`` naming what the sensors gave. The errors a user reads must be in that
quantity, so the measured and the model's displacement are both differentiated back with the same
linear operator ``D^p`` (p = 0, 1, 2 for displacement, velocity, acceleration) and compared:

- **periodic records** (``Signals.period`` set, whole periods): line by line over the record,
  ``X(k) (jω_k)^p`` with the DC line (and the Nyquist line) set to zero. For the measured channel
  this returns exactly the measured acceleration on the lines the periodic integration kept
  (:func:`bayesnsi.nsi.periodic_integration`), so the error is the one against the sensor signal
  in the integration band.
- **other records**: the fourth-order central difference of :func:`bayesnsi.signals.differentiate`
  applied p times (relative gain error about ``-(ωΔt)⁴/30`` per pass: 0.5 % at a tenth of the
  sampling rate, 3e-4 at a twentieth); the measured displacement is already band-limited by the integration filter,
  so this is the band-limited measured acceleration, and the model's output passes the same filter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .signals import MEASURED_QUANTITIES, differentiate

__all__ = ["MeasuredError", "measured_error", "to_measured"]

_ORDER = {q: p for p, q in enumerate(MEASURED_QUANTITIES)}


def to_measured(displacement, fs: float, quantity: str, period: int | None = None, realisations: int = 1) -> np.ndarray:
    """Displacements differentiated into the measured ``quantity`` (see the module docstring).

    Parameters
    ----------
    displacement : array_like, shape (n_samples, n_channels)
        Displacements [m].
    fs : float
        Sampling frequency [Hz].
    quantity : {"displacement", "velocity", "acceleration"}
        What the sensors measured.
    period : int, optional
        Samples per period; line by line when the record holds whole periods, else finite differences.
    realisations : int
        Equal-length realisations one after the other (``Signals.realisations``), each differentiated
        line by line on its own.

    Returns
    -------
    ndarray, shape (n_samples, n_channels)
        The quantity in the displacement's units per second^p (m, m/s, m/s²).
    """
    x = np.asarray(displacement, dtype=float)
    order = _ORDER[quantity]
    if order == 0:
        return x
    if realisations > 1 and period is not None:  # each realisation on its own lines (new phases: no continuity)
        parts = np.split(x, realisations)
        return np.concatenate([to_measured(part, fs, quantity, period) for part in parts])
    n = len(x)
    if period is not None and n % period == 0:
        spectrum = np.fft.rfft(x, axis=0)
        omega = 2 * np.pi * np.fft.rfftfreq(n, 1.0 / fs)
        factor = (1j * omega) ** order
        factor[0] = 0.0
        if n % 2 == 0:
            factor[-1] = 0.0
        return np.fft.irfft(spectrum * factor[:, None], n=n, axis=0)
    for _ in range(order):
        x = differentiate(x, fs)
    return x


@dataclass(frozen=True)
class MeasuredError:
    """Error of a model's response in the measured quantity, per channel and overall.

    Attributes
    ----------
    quantity : str
        "displacement", "velocity" or "acceleration".
    rmse : float
        RMS over all channels of the error (units of the quantity).
    nrmse : float
        ``sqrt(mean_c(mean(e_c²) / mean(y_c²)))`` in the quantity.
    rmse_per_channel, nrmse_per_channel : tuple of float
        Per output channel.
    """

    quantity: str
    rmse: float
    nrmse: float
    rmse_per_channel: tuple[float, ...]
    nrmse_per_channel: tuple[float, ...]

    def to_dict(self) -> dict:
        """Plain-data form, as written to results.json."""
        return {"quantity": self.quantity, "rmse": self.rmse, "nrmse": self.nrmse,
                "rmse_per_channel": list(self.rmse_per_channel), "nrmse_per_channel": list(self.nrmse_per_channel)}


def measured_error(measured, predicted, signals, skip: int = 0) -> MeasuredError:
    """Error of ``predicted`` against ``measured`` displacements, in ``signals.measured``.

    Parameters
    ----------
    measured, predicted : array_like, shape (n_samples, n_channels)
        Measured and model displacements of the whole record of ``signals``.
    signals : Signals
        The record (``fs``, ``period`` and ``measured`` are read).
    skip : int
        Leading samples left out of the error after differentiating (e.g. the samples that fixed
        the initial state of a closed-loop simulation).

    Returns
    -------
    MeasuredError
    """
    quantity = getattr(signals, "measured", "displacement")
    r = getattr(signals, "realisations", 1)
    y = to_measured(measured, signals.fs, quantity, signals.period, r)[skip:]
    e = y - to_measured(predicted, signals.fs, quantity, signals.period, r)[skip:]
    mean_square = np.mean(e**2, axis=0)
    power = np.mean(y**2, axis=0)
    ratio = mean_square / np.where(power > 0, power, np.inf)
    return MeasuredError(
        quantity, float(np.sqrt(np.mean(mean_square))), float(np.sqrt(np.mean(ratio))),
        tuple(float(v) for v in np.sqrt(mean_square)), tuple(float(v) for v in np.sqrt(ratio)),
    )
