"""Sensor noise of measured records: levels, models and draws (docs/method.md §10-11); numpy/scipy only.

One home for every estimate of "the noise the data carry":

- :mod:`~bayesnsi.noise.levels`: white-noise levels from high-order differences, and the joint
  displacement/velocity noise of a record (:func:`measured_noise_std`);
- :mod:`~bayesnsi.noise.accelerometer`: white noise of measured accelerations before integration;
- :mod:`~bayesnsi.noise.integrated`: that noise and the integration recipe a loader applied
  (:class:`AccelerationNoise`, carried by :attr:`Signals.acceleration_noise <bayesnsi.signals.Signals>`);
- :mod:`~bayesnsi.noise.periodic`: whole periods, their deviations and scatter (:class:`PeriodNoise`);
- :mod:`~bayesnsi.noise.model`: the :class:`NoiseModel` protocol and its variants, chosen once per
  record by :func:`noise_model`; the noise replicates, the adequacy yardstick and the band check
  draw from it;
- :mod:`~bayesnsi.noise.lines`: the spectral lines where a record holds data;
- :mod:`~bayesnsi.noise.lowband`: load-time checks of an integration band against the motion and
  the noise below and near its lower edge.
"""

from .accelerometer import acceleration_noise_std
from .integrated import NOISE_SOURCES, AccelerationNoise, acceleration_noise_of, edge_samples
from .levels import column_std, measured_noise_std, row_var, white_noise_std
from .lines import SpectralLines, spectral_lines
from .model import (
    IntegratedSensorNoise,
    NoiseDraw,
    NoiseModel,
    PeriodScatterNoise,
    WhiteSensorNoise,
    noise_model,
    noisy_copy,
    velocity_noise_std,
)
from .periodic import PeriodNoise, period_blocks, period_deviations, period_noise, period_scatter_std

__all__ = [
    "AccelerationNoise",
    "IntegratedSensorNoise",
    "NOISE_SOURCES",
    "NoiseDraw",
    "NoiseModel",
    "PeriodNoise",
    "PeriodScatterNoise",
    "SpectralLines",
    "WhiteSensorNoise",
    "acceleration_noise_of",
    "acceleration_noise_std",
    "column_std",
    "edge_samples",
    "measured_noise_std",
    "noise_model",
    "noisy_copy",
    "period_blocks",
    "period_deviations",
    "period_noise",
    "period_scatter_std",
    "row_var",
    "spectral_lines",
    "velocity_noise_std",
    "white_noise_std",
]
