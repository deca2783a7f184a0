"""Nonlinear subspace identification (docs/method.md §2-5); numpy/scipy only."""

from ._grounded import grounded_modes
from ._hankel import HankelCorrelations
from .feedback import extended_input
from .free_body import PhysicalParameters, is_free_body, physical_parameters
from .identify import hankel_correlations, identify
from .inverse import ForcePrediction, force_affine, force_noise_std, force_prediction, short_horizon_nrmse
from .order import select_order, stabilization
from .periodic import (
    BestLinearApproximation,
    PeriodicSpectra,
    best_linear_approximation,
    excited_lines,
    period_dft,
    period_spectra,
    periodic_integration,
)
from .physics import CoefficientEstimate, Mode, coefficient_spectrum, split_poles
from .predictor import predictor_reconstruction
from .reconstruct import (
    AffineReconstruction,
    Reconstruction,
    affine_reconstruction,
    initial_state,
    nrmse,
    reconstruct,
)
from .result import IdentificationFit, NSIResult
from .statespace import StateSpaceModel

__all__ = [
    "grounded_modes",
    "identify",
    "PhysicalParameters",
    "is_free_body",
    "physical_parameters",
    "ForcePrediction",
    "force_prediction",
    "force_affine",
    "force_noise_std",
    "short_horizon_nrmse",
    "hankel_correlations",
    "HankelCorrelations",
    "IdentificationFit",
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
    "PeriodicSpectra",
    "BestLinearApproximation",
    "period_spectra",
    "period_dft",
    "excited_lines",
    "best_linear_approximation",
    "periodic_integration",
]
