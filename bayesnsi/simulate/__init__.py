"""Reference simulators: structures, band-limited excitation, RK4 and the docs/method.md §8 cases.

numpy/scipy only. Signals follow the library convention ``(n_samples, n_channels)``; DOFs
are numbered from 1; forces in N, displacements in m, frequencies in Hz (``*_hz``).
"""

from .cases import (
    CASES,
    ReferenceCase,
    cantilever_beam_case,
    negative_stiffness_parameters,
    negative_stiffness_twin,
    simulate_case,
    simulate_cases,
    three_dof,
    two_dof,
)
from .excitation import Excitation, band_limited_gaussian, fft_interpolate, from_samples
from .gvt import GVT_BAND_HZ, GVT_JOINT, GVT_SENSORS, GVT_SHAKER, GVTRecord, gvt_records, gvt_structure
from .hysteretic import simulate_hysteretic_response
from .integrate import Response, add_output_noise, simulate_response
from .multisine import multisine, multisine_lines
from .records import CaseSetup
from .reference import MAX_SIMULATION_BYTES, case_setup, simulation_bytes
from .rk4 import rk4_modal_error
from .structures import cantilever_beam, chain_system, modal_damping, modal_parameters, state_matrix, underlying_frf
from .undeclared import UNDECLARED_CASES, MissingEffect, UndeclaredCase, effect_sizes, undeclared_case, undeclared_cases

__all__ = [
    # structures
    "chain_system",
    "cantilever_beam",
    "modal_damping",
    "modal_parameters",
    "state_matrix",
    "underlying_frf",
    # excitation
    "Excitation",
    "band_limited_gaussian",
    "from_samples",
    "fft_interpolate",
    "multisine",
    "multisine_lines",
    # simulated ground vibration test (periodic)
    "GVTRecord",
    "gvt_records",
    "gvt_structure",
    "GVT_BAND_HZ",
    "GVT_JOINT",
    "GVT_SENSORS",
    "GVT_SHAKER",
    # integration
    "Response",
    "simulate_response",
    "simulate_hysteretic_response",
    "add_output_noise",
    "rk4_modal_error",
    # reference cases
    "ReferenceCase",
    "two_dof",
    "three_dof",
    "cantilever_beam_case",
    "negative_stiffness_twin",
    "negative_stiffness_parameters",
    "CASES",
    "simulate_case",
    "simulate_cases",
    "CaseSetup",
    "case_setup",
    "simulation_bytes",
    "MAX_SIMULATION_BYTES",
    # undeclared-effect cases for closing the loop (docs/method.md §7)
    "UndeclaredCase",
    "MissingEffect",
    "UNDECLARED_CASES",
    "undeclared_case",
    "undeclared_cases",
    "effect_sizes",
]
