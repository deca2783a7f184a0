"""Machinery of the reference cases: the case record, the registry and the batched run.

A case is defined once, by a *set-up function* decorated with :func:`reference_case`: it takes
the case's parameters (with their defaults: duration, fs, oversample, ...) and returns a
:class:`CaseSetup` (structure, excitation, true terms and coefficients, candidates, recommended
:class:`~bayesnsi.options.NSIOptions`). The decorator registers it under its name with its
default output noise and returns the public case function ``f(seed=0, noise_percent=default,
**parameters) -> ReferenceCase``. :func:`simulate_cases` runs several seeds in one batched time
loop; every random draw happens in :func:`run_setup`, in a fixed order per seed (excitation,
then displacement noise, then velocity noise).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._limits import check_allocation
from ..exceptions import InputDataError
from ..signals import Signals
from .hysteretic import simulate_hysteretic_response
from .integrate import Response, add_output_noise, simulate_response
from .records import CaseSetup, ReferenceCase
from .structures import modal_parameters

__all__ = [
    "ReferenceCase",
    "CaseSetup",
    "CASES",
    "MAX_SIMULATION_BYTES",
    "case_setup",
    "n_samples_of",
    "reference_case",
    "run_setup",
    "simulate_case",
    "simulate_cases",
    "simulation_bytes",
]

MAX_SIMULATION_BYTES = 8 * 2**30
"""Largest estimated memory [bytes] of one simulation call (8 GiB) unless ``BAYESNSI_MAX_MEMORY`` is set."""


_PARAMETERS = "    Parameters\n    ----------\n"
_COMMON_PARAMETERS = """    seed : int or numpy.random.Generator
        Seed of the excitation, then of the output noise (a non-negative integer).
    noise_percent : float
        Output noise std as a percentage of each channel's std.
    duration : float
        Record length [s].
    fs : float
        Sampling frequency [Hz].
"""


@dataclass(frozen=True)
class _Entry:
    setup: Callable[..., CaseSetup]
    noise_percent: float


_REGISTRY: dict[str, _Entry] = {}

CASES: dict[str, Callable[..., ReferenceCase]] = {}
"""Registry of the reference cases: name -> case function (filled by :func:`reference_case`)."""


def reference_case(name: str, noise_percent: float):
    """Register a case set-up function under ``name`` and return its public case function.

    Parameters
    ----------
    name : str
        Registry name.
    noise_percent : float
        Default output noise [%] of the case.

    Returns
    -------
    callable
        A decorator. The decorated set-up function ``setup(**parameters) -> CaseSetup`` becomes
        ``case(seed=0, noise_percent=noise_percent, **parameters) -> ReferenceCase``: the set-up's
        parameters and defaults after ``seed`` and ``noise_percent``, and its docstring with
        ``seed``, ``noise_percent``, ``duration`` and ``fs`` prepended to its Parameters section
        (the set-up documents its other parameters).
    """

    def decorate(setup: Callable[..., CaseSetup]) -> Callable[..., ReferenceCase]:
        params = list(inspect.signature(setup).parameters.values())
        head = [
            inspect.Parameter("seed", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=0),
            inspect.Parameter("noise_percent", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=noise_percent),
        ]
        signature = inspect.Signature(head + params, return_annotation=ReferenceCase)

        @functools.wraps(setup)
        def case(*args, **kwargs) -> ReferenceCase:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            values = dict(bound.arguments)
            seed, noise = values.pop("seed"), values.pop("noise_percent")
            return simulate_cases(name, [seed], noise, **values)[0]

        case.__signature__ = signature  # type: ignore[attr-defined]  # what help() and inspect show
        case.__doc__ = (setup.__doc__ or "").replace(_PARAMETERS, _PARAMETERS + _COMMON_PARAMETERS, 1)
        _REGISTRY[name] = _Entry(setup, float(noise_percent))
        CASES[name] = case
        return case

    return decorate


def simulate_case(name: str, seed=0, noise_percent: float | None = None, **kwargs) -> ReferenceCase:
    """Run the reference case called ``name`` (a key of :data:`CASES`).

    Parameters
    ----------
    name : {"two-dof", "beam", "negative-stiffness", "three-dof"}
        Registry name.
    seed : int or numpy.random.Generator
        Seed of the excitation and of the noise (a non-negative integer).
    noise_percent : float, optional
        Output noise [%]; the case's default when None.
    **kwargs
        Further parameters of the case (duration, fs, oversample, ...).

    Returns
    -------
    ReferenceCase

    Raises
    ------
    InputDataError
        For an unknown case, a negative seed, bad parameters or a simulation above the memory
        limit (:data:`MAX_SIMULATION_BYTES`, ``BAYESNSI_MAX_MEMORY``).
    """
    return simulate_cases(name, [seed], noise_percent, **kwargs)[0]


def simulate_cases(
    name: str, seeds: Sequence, noise_percent: float | None = None, **kwargs
) -> tuple[ReferenceCase, ...]:
    """Run several seeds of one case in one batched time loop.

    Parameters
    ----------
    name : {"two-dof", "beam", "negative-stiffness", "three-dof"}
        Registry name.
    seeds : sequence of int or numpy.random.Generator
        One realisation per seed; each is identical (to rounding) to ``simulate_case(name,
        seed)``.
    noise_percent : float, optional
        Output noise [%]; the case's default when None.
    **kwargs
        Further parameters of the case.

    Returns
    -------
    tuple of ReferenceCase

    Raises
    ------
    InputDataError
        As :func:`simulate_case`, or for an empty ``seeds``.
    """
    seeds = list(seeds)
    if not seeds:
        raise InputDataError("simulate_cases needs at least one seed")
    setup = case_setup(name, **kwargs)
    noise = _REGISTRY[name].noise_percent if noise_percent is None else float(noise_percent)
    return run_setup(setup, seeds, noise)


def case_setup(name: str, **kwargs) -> CaseSetup:
    """The registry entry ``name`` evaluated at the given parameters (no random draw).

    Parameters
    ----------
    name : str
        Key of :data:`CASES`.
    **kwargs
        Parameters of the case (duration, fs, oversample, ...); defaults for the others.

    Returns
    -------
    CaseSetup

    Raises
    ------
    InputDataError
        For an unknown case or parameter name, or bad parameter values.
    """
    if name not in _REGISTRY:
        raise InputDataError(f"unknown case {name!r}; choose one of {sorted(_REGISTRY)}")
    setup = _REGISTRY[name].setup
    known = inspect.signature(setup).parameters
    unknown = sorted(set(kwargs) - set(known))
    if unknown:
        raise InputDataError(f"case {name!r} has no parameter {unknown[0]!r}; it takes {list(known)}")
    return setup(**kwargs)


def simulation_bytes(setup: CaseSetup, n_batch: int = 1) -> int:
    """Estimated memory [bytes] of simulating ``n_batch`` realisations of ``setup``.

    Counts 8-byte floats of ``n_samples`` × channels per realisation: the fine excitation
    (``oversample`` × force channels, held three times: the draw, its interpolation and the
    batched copy the integrator reads), the state history and the four response arrays
    (6 N for N DOFs) and the noisy and clean signals (4 outputs + 2 forces).

    Parameters
    ----------
    setup : CaseSetup
        The case.
    n_batch : int
        Number of realisations simulated together.

    Returns
    -------
    int
    """
    n_force, n_dofs, n_out = len(setup.force_dofs), setup.M.shape[0], len(setup.output_dofs)
    channels = 3 * setup.oversample * n_force + 6 * n_dofs + 4 * n_out + 2 * n_force
    return int(8 * n_batch * setup.n_samples * channels)


def run_setup(setup: CaseSetup, seeds: list, noise_percent: float) -> tuple[ReferenceCase, ...]:
    """Simulate one realisation of ``setup`` per seed, in one batched time loop.

    Parameters
    ----------
    setup : CaseSetup
        The case.
    seeds : list of int or numpy.random.Generator
        Non-negative integer seeds (or Generators); each seeds the excitation then the noise.
    noise_percent : float
        Output noise [%] of each channel's std.

    Returns
    -------
    tuple of ReferenceCase

    Raises
    ------
    InputDataError
        For a negative seed or noise level, or when :func:`simulation_bytes` exceeds the
        memory limit.
    """
    if not (np.isfinite(noise_percent) and noise_percent >= 0):
        raise InputDataError(f"noise_percent must be a non-negative number, got {noise_percent!r}")
    for seed in seeds:
        if isinstance(seed, (int, np.integer)) and seed < 0:
            raise InputDataError(f"seed must be a non-negative integer, got {seed}")
    check_allocation(
        simulation_bytes(setup, len(seeds)),
        f"simulating {len(seeds)} x {setup.n_samples} samples of case {setup.name!r}",
        default=MAX_SIMULATION_BYTES,
    )
    rngs = [np.random.default_rng(s) for s in seeds]
    excitations = [setup.excitation(rng) for rng in rngs]
    force_fine = np.stack([e.fine for e in excitations]) * setup.force_factor
    hysteretic = any(t.expr.memory is not None for t in setup.terms)  # z as a state of the integration
    simulator = simulate_hysteretic_response if hysteretic else simulate_response
    response = simulator(
        setup.M,
        setup.C,
        setup.K,
        setup.force_dofs,
        force_fine,
        setup.fs * setup.oversample,
        setup.oversample,
        setup.terms,
        setup.coefficients,
    )
    freqs, zetas = modal_parameters(setup.M, setup.C, setup.K)
    cols = [d - 1 for d in setup.output_dofs]
    settings_common = {
        "oversample": setup.oversample,
        "rk4_step_s": response.step,
        "simulation_wall_time_s": response.elapsed_s,
        "batch_size": len(seeds),
    }
    cases = []
    for b, (seed, rng, exc) in enumerate(zip(seeds, rngs, excitations)):
        single = _pick(response, b)
        force = exc.samples * setup.force_factor
        disp, vel = single.displacement[:, cols], single.velocity[:, cols]
        noisy_disp = add_output_noise(disp, noise_percent, rng)
        noisy_vel = add_output_noise(vel, noise_percent, rng)
        common: dict[str, Any] = dict(fs=setup.fs, input_dofs=setup.force_dofs, output_dofs=setup.output_dofs)
        cases.append(
            ReferenceCase(
                name=setup.name,
                signals=Signals(force=force, displacement=noisy_disp, velocity=noisy_vel, **common),
                clean=Signals(force=force, displacement=disp, velocity=vel, **common),
                response=single,
                M=setup.M,
                C=setup.C,
                K=setup.K,
                true_terms=setup.terms,
                true_coefficients=setup.coefficients.copy(),
                true_model=setup.true_model,
                exact_frequencies_hz=freqs,
                exact_damping_ratios=zetas,
                candidates=setup.candidates,
                recommended=setup.recommended,
                seed=int(seed) if isinstance(seed, (int, np.integer)) else None,
                noise_percent=noise_percent,
                excitation=exc,
                settings={**setup.settings, **settings_common},
                title=setup.title,
            )
        )
    return tuple(cases)


def n_samples_of(duration: float, fs: float) -> int:
    """Number of samples of a ``duration`` [s] record at ``fs`` [Hz] (at least 10).

    Raises
    ------
    InputDataError
        If either is not a positive finite number or the record is shorter than 10 samples.
    """
    if not (np.isfinite(duration) and duration > 0 and np.isfinite(fs) and fs > 0):
        raise InputDataError(f"duration and fs must be positive numbers, got {duration!r} s and {fs!r} Hz")
    n = int(round(duration * fs))
    if n < 10:
        raise InputDataError(f"{duration} s at {fs} Hz gives only {n} samples; lengthen the record")
    return n


def _pick(response: Response, b: int) -> Response:
    if response.displacement.ndim == 2:
        return response
    return Response(
        displacement=response.displacement[b],
        velocity=response.velocity[b],
        acceleration=response.acceleration[b],
        nonlinear_force=response.nonlinear_force[b],
        force=response.force[b],
        fs=response.fs,
        step=response.step,
        n_steps=response.n_steps,
        elapsed_s=response.elapsed_s,
    )
