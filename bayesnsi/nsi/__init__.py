"""Nonlinear subspace identification (SPEC sections 2-5); numpy/scipy only."""

from .identify import HankelCorrelations, NSIResult, extended_input, hankel_correlations, identify, select_order, stabilization
from .physics import CoefficientEstimate, Mode, coefficient_spectrum, split_poles
from .reconstruct import (
    AffineReconstruction,
    Reconstruction,
    affine_reconstruction,
    initial_state,
    nrmse,
    predictor_reconstruction,
    reconstruct,
)
from .statespace import StateSpaceModel
from .tables import coefficients_table, modes_table

__all__ = [
    "identify",
    "hankel_correlations",
    "HankelCorrelations",
    "NSIResult",
    "extended_input",
    "select_order",
    "stabilization",
    "CoefficientEstimate",
    "Mode",
    "coefficient_spectrum",
    "split_poles",
    "Reconstruction",
    "AffineReconstruction",
    "affine_reconstruction",
    "predictor_reconstruction",
    "reconstruct",
    "initial_state",
    "nrmse",
    "StateSpaceModel",
    "modes_table",
    "coefficients_table",
]
