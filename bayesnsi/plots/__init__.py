"""Figures (matplotlib only). Functions return Figures; they never save or show."""

from .nsi import plot_coefficient_spectrum, plot_frf, plot_singular_values, plot_stabilization

__all__ = ["plot_singular_values", "plot_stabilization", "plot_frf", "plot_coefficient_spectrum"]
