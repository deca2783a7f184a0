"""Figures (matplotlib only). Functions return Figures; they never save or show.

Axes carry units: pass ``units`` (:func:`bayesnsi.io.units.data_units` of a config, or a
:class:`bayesnsi.io.units.ChannelUnits`); without them the axes say "data units".
"""

from .hysteresis import plot_hysteresis_loop
from .nsi import (
    plot_coefficient_spectra,
    plot_coefficient_spectrum,
    plot_frf,
    plot_model_order,
    plot_singular_values,
    plot_stabilization,
)
from .report import plot_band_ratios, plot_bayes_factors, plot_reconstruction
from .selection import (
    plot_effect_force,
    plot_model_probabilities,
    plot_posterior_pairs,
    plot_reconstruction_errors,
    plot_traces,
)

__all__ = [
    "plot_singular_values",
    "plot_stabilization",
    "plot_model_order",
    "plot_frf",
    "plot_coefficient_spectrum",
    "plot_coefficient_spectra",
    "plot_model_probabilities",
    "plot_bayes_factors",
    "plot_band_ratios",
    "plot_reconstruction",
    "plot_reconstruction_errors",
    "plot_posterior_pairs",
    "plot_traces",
    "plot_effect_force",
    "plot_hysteresis_loop",
]
