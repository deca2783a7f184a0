"""Time-domain nonlinear subspace identification, NSI (docs/method.md §2-4).

The nonlinear terms enter as extra "feedback" inputs ``u = [f; -n_1(y, ẏ); ...; -n_q]``
(paper Eq. 8, :mod:`bayesnsi.nsi.feedback`); a linear subspace identification of the
extended-input system gives the underlying linear model and, through the extended FRF, the
coefficients λ_i(ω). The model order is chosen in :mod:`bayesnsi.nsi.order`, the result is an
:class:`~bayesnsi.nsi.result.NSIResult`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..exceptions import InputDataError, OrderError, SpuriousPoleWarning, UnstableModelError
from ..noise import white_noise_std
from ..options import NSIOptions
from ..signals import Signals
from . import _hankel, _subspace
from ._eiv import refine_prediction_error, refine_prediction_error_bc
from ._frequency import identify_frequency
from ._hankel import HankelCorrelations, correlation_key
from ._line_information import band_weighting
from ._output_error import refine_output_error
from ._output_error import refine_poles as _refine_poles
from ._stabilise import pole_text, reflect_out_of_band
from ._virtual_mode import mirror_undamped, physical_mirrored
from .feedback import as_candidate, extended_input, resolve_input_hold, working_signals
from .free_body import auto_stiffness, free_model, rigid_body_poles, stabilise
from .order import auto_order, oblique_decomposition, scaled_stack
from .physics import (
    CoefficientEstimate,
    band_coefficients,
    coefficient_spectrum,
    default_band,
    identification_routes,
    split_poles,
)
from .result import IdentificationFit, NSIResult
from .statespace import StateSpaceModel

__all__ = ["hankel_correlations", "identify"]

_BAND_POINTS = 512


def hankel_correlations(signals: Signals, candidate=None, options: NSIOptions | None = None) -> HankelCorrelations:
    """Lagged products of ``candidate``'s scaled ``[u, y]`` for reuse by :func:`identify`.

    Parameters
    ----------
    signals : Signals
        Measured forces and responses.
    candidate : CandidateModel, sequence of Term or (expr, at) pairs, or None
        The candidate whose products later candidates (with more terms) reuse.
    options : NSIOptions, optional
        Only ``block_rows``, ``velocity_method``, ``input_hold`` and ``upsample`` change the
        products.

    Returns
    -------
    HankelCorrelations
    """
    options = _as_options(options)
    block_rows, velocity_method, upsample = options.block_rows, options.velocity_method, options.upsample
    cand = as_candidate(candidate)
    stiffness = _fixed_stiffness(options)
    work = stabilise(working_signals(signals, int(upsample)), stiffness)
    hold = resolve_input_hold(options.input_hold, cand.terms)
    u = extended_input(work, cand.terms, velocity_method, hold)
    stack = scaled_stack(u, np.asarray(work.displacement), block_rows)
    return HankelCorrelations(
        term_names=tuple(t.name for t in cand.terms),
        key=correlation_key(len(u), block_rows, hold, velocity_method, upsample, stiffness),
        scales=np.concatenate([stack.u_scale, stack.y_scale]),
        lagged=_hankel.lagged_products(stack, 2 * block_rows),
    )


def identify(
    signals: Signals,
    candidate=None,
    options: NSIOptions | None = None,
    *,
    correlations: HankelCorrelations | None = None,
    start: NSIResult | None = None,
) -> NSIResult:
    """Identify one candidate model by nonlinear subspace identification.

    The candidate's nonlinear terms become extra inputs ``-n_i(y, ẏ)`` of a linear system
    (paper Eq. 8); a subspace identification of that extended-input system (weighted oblique
    projection, order from the singular values) gives ``A, B, C, D``, the physical modes, and
    the coefficients λ_i as the band mean of the real part of λ_i(ω) from the extended FRF
    (paper Eqs. 24-32).

    Parameters
    ----------
    signals : Signals
        Measured forces and displacements (velocities optional).
    candidate : CandidateModel, sequence of Term or (expr, at) pairs, or None
        The nonlinear terms; None identifies a linear model.
    options : NSIOptions, optional
        Block rows, order, estimators of B, C, D, grid refinement, band (defaults:
        ``NSIOptions()``; each field is described there, measurements behind the choices in
        ``docs/measurements.md``). ``domain="frequency"`` identifies a periodic record
        (``signals.period`` set) on its excited lines instead (FNSI, :mod:`._frequency`): the
        same result object, with ``options.domain == "frequency"``; only that route takes a
        record of several ``signals.realisations`` (their lines stacked into one estimate).
    correlations : HankelCorrelations, optional
        Lagged products of a candidate whose terms this one's start with
        (:func:`hankel_correlations`, same data and settings): only the products of the added
        terms' inputs are computed; the same result (to rounding). Ignored when they do not
        apply or with ``route="lq"``.
    start : NSIResult, optional
        Frequency route: refined from it (same order, as many terms).

    Returns
    -------
    NSIResult
        The discrete-time model in physical units, singular values, order, modes, discarded
        poles, coefficients and the settings used.

    Raises
    ------
    InputDataError
        When ``signals`` is not a Signals object or ``options`` not NSIOptions.
    BlockRowsError
        When the record is too short for the block rows.
    OrderError
        When the requested order is impossible with these block rows and outputs.
    NotIdentifiableError
        When a term reads an unmeasured DOF, is constant, or its coefficient cannot be
        separated with the measured forces and responses.
    UnstableModelError
        When the identified model is unstable or has no physical mode (a rigid-body pole, z = 1,
        is not a failure: with ``virtual_stiffness = "auto"`` it is identified with a known
        spring on the input, see :mod:`bayesnsi.nsi.free_body`).

    Warns
    -----
    SpuriousPoleWarning
        When some identified poles are real or have a damping ratio outside (0, 1).

    See Also
    --------
    NSIResult.to_statespace, NSIResult.innovation_form : the linear model for scipy/control,
        its Kalman gain. The method in brief: ``docs/method.md`` §2-4.

    References
    ----------
    R. Zhu, Q. Fei, D. Jiang, S. Marchesiello, D. Anastasio, "Bayesian Model Selection in
    Nonlinear Subspace Identification", AIAA Journal, doi:10.2514/1.J060782: Eq. 8 (extended
    input), Sec. II (subspace step), Eqs. 24-32 (extended FRF and coefficients).

    Examples
    --------
    >>> from bayesnsi.options import NSIOptions
    >>> from bayesnsi.simulate import simulate_case
    >>> case = simulate_case("two-dof", seed=0)
    >>> result = identify(case.signals, case.true_terms, NSIOptions(block_rows=20, order=4))
    >>> result.order, len(result.modes)
    (4, 2)
    >>> bool(abs(result.coefficient_values[0] / case.true_coefficients[0] - 1) < 0.1)
    True
    """
    if not isinstance(signals, Signals):
        raise InputDataError(f"identify() needs a Signals object, got {type(signals).__name__}")
    options = _as_options(options)
    cand = as_candidate(candidate)
    identification_routes(cand.terms, signals.input_dofs, signals.output_dofs)
    if options.domain == "frequency":
        return identify_frequency(signals, cand, options, start)
    if signals.realisations > 1:  # a Hankel block across a boundary would join two unrelated steady states
        raise InputDataError(
            f"the time route cannot estimate from {signals.realisations} realisations at once (its block rows would "
            'span their boundaries); use the frequency route ([nsi] domain = "frequency"), which stacks their lines, '
            "or estimate from one realisation (realisations = 1)"
        )
    block_rows, upsample, velocity_method = options.block_rows, int(options.upsample), options.velocity_method
    data_fs, measured = signals.fs, signals
    stiffness = _fixed_stiffness(options)
    signals = stabilise(working_signals(signals, upsample), stiffness)
    input_hold = resolve_input_hold(options.input_hold, cand.terms)
    u = extended_input(signals, cand.terms, velocity_method, input_hold)
    stack = scaled_stack(u, np.asarray(signals.displacement), block_rows)
    lagged = None
    if options.route == "correlation" and correlations is not None:
        key = correlation_key(len(u), block_rows, input_hold, velocity_method, upsample, stiffness)
        lagged = correlations.extended(cand.terms, key, stack)
    data, left, singular_values = oblique_decomposition(stack, block_rows, options.route, lagged)
    order = _model_order(options, singular_values, block_rows, stack.y.shape[1])
    A, C_s = _subspace.system_matrices_ac(left, singular_values, order, stack.y.shape[1])
    eigenvalues = np.linalg.eigvals(A)
    radius = np.max(np.abs(eigenvalues))
    colocated = bool(set(signals.input_dofs) & set(signals.output_dofs))
    if options.virtual_stiffness == "auto" and _free_body_failure(eigenvalues, signals.dt, len(u), colocated):
        # a free body: identify again with a known spring on the input (bayesnsi.nsi.free_body)
        fixed = options.replace(virtual_stiffness=auto_stiffness(measured))
        return identify(measured, cand, fixed, correlations=correlations)
    stabilised = (reflect_out_of_band(A, signals.dt, options.band_hz, np.asarray(signals.force)) if radius >= 1.0
                  else (A, eigenvalues[:0]))
    virtual_mode = eigenvalues[:0]
    if stabilised is None and stiffness:  # the virtual spring's mode of a body with no damping to ground
        mirrored = mirror_undamped(A, signals.dt)
        if mirrored is not None:
            stabilised, virtual_mode = (mirrored[0], eigenvalues[:0]), mirrored[1]
    if stabilised is None:
        unstable = eigenvalues[(np.abs(eigenvalues) >= 1.0) & (eigenvalues.imag >= 0)]
        raise UnstableModelError(
            f"candidate {cand.name!r}: the identified underlying linear model is unstable "
            f"(largest |eigenvalue of A| = {radius:.4f}; unstable poles at {pole_text(unstable, signals.dt)}) inside "
            "[nsi] band_hz, at a frequency the force excites, or with no band given; try another order (near twice "
            "the number of modes in the band: the stabilisation diagram, bayesnsi.nsi.stabilization, shows which "
            "orders hold them) or number of block rows, or reconsider the candidate's terms"
        )
    A, reflected = stabilised
    if len(reflected):  # outside the band the data inform: mirrored into the unit circle (_stabilise.py)
        warnings.warn(f"candidate {cand.name!r}: unstable pole(s) outside the band {options.band_hz} Hz, "
                      f"where the force has no power, at "
                      f"{pole_text(reflected, signals.dt)} mirrored into the unit circle; the candidate is kept",
                      SpuriousPoleWarning, stacklevel=2)
    noise_std = white_noise_std(stack.y[::upsample])  # at the data's samples the noise is white
    if options.refine_poles is not None:
        A, _ = _refine_poles(A, stack.u, stack.y, signals.dt, options.refine_poles, noise_std=noise_std)
    B, C, D = _input_output_matrices(options, data, A, C_s, stack, signals, cand.terms, noise_std)
    model = StateSpaceModel(A=A, B=B, C=C, D=D, dt=signals.dt)
    band_modes, _ = split_poles(model.poles, signals.dt)
    if not band_modes:
        raise UnstableModelError(
            f"candidate {cand.name!r}: no physical mode among the {order} identified poles; "
            "check the order (singular values) and the sampling rate"
        )
    modes, spurious, rigid = band_modes, model.poles[:0], np.zeros(0, dtype=complex)
    below: list = []
    if stiffness:  # the physical poles are those of the free model (spring removed)
        free = free_model(model, stiffness, signals.input_dofs, signals.output_dofs)
        rigid = rigid_body_poles(free.poles_discrete, signals.dt, len(u),
                                 options.band_hz or default_band(band_modes, signals.fs))
        modes, spurious = split_poles(free.poles, signals.dt)
        modes = [m for m in modes if not np.any(np.isclose(m.pole, rigid))]  # a slow pair of the double s = 0
        if physical := physical_mirrored(virtual_mode, modes, signals.dt):
            raise UnstableModelError(
                f"candidate {cand.name!r}: the identified model has an unstable mode at "
                f"{', '.join(f'{f:.3g}' for f in physical)} Hz (not the virtual spring's mode of the free body); "
                "try another order or number of block rows, or reconsider the candidate's terms"
            )
        spurious = np.array([s for s in spurious if not np.any(np.isclose(s, rigid))], dtype=complex)
    else:
        _, spurious = split_poles(model.poles, signals.dt)
        modes, below = informed_modes(band_modes, measured)
        if below:  # integrated sensors: no motion below the integration band, so no mode can be read there
            band_modes = modes
            spurious = np.concatenate([spurious, [m.pole for m in below], [np.conj(m.pole) for m in below]])
            warnings.warn(
                f"candidate {cand.name!r}: {len(below)} mode(s) at {', '.join(f'{m.frequency_hz:.3g}' for m in below)} "
                "Hz below the band the sensors were integrated in (the data hold no motion there), or heavily damped "
                "at its lower edge (the integrated noise), set aside as non-physical; see NSIResult.spurious_poles",
                SpuriousPoleWarning, stacklevel=2,
            )
    if len(spurious):
        warnings.warn(
            f"candidate {cand.name!r}: {len(spurious)} of {order} poles discarded as non-physical "
            f"(real{', below the integration band' if below else ''} or with damping outside (0, 1)); see "
            "NSIResult.spurious_poles",
            SpuriousPoleWarning,
            stacklevel=2,
        )
    band = tuple(float(b) for b in (options.band_hz or default_band(band_modes, signals.fs)))
    weighting = band_weighting(options.band_mean, u, noise_std, measured)
    resolved = options.replace(
        block_rows=int(block_rows), order=order, band_hz=band,
        band_mean="plain" if weighting is None else "information", velocity_method=velocity_method,
        input_hold=input_hold, upsample=upsample, virtual_stiffness=stiffness,
    )
    fit = IdentificationFit(
        n_samples=int(len(u)) // upsample, fs=data_fs,
        reflected_poles_hz=tuple(float(abs(np.angle(z)) / (2 * np.pi * signals.dt)) for z in reflected),
        virtual_mode_mirrored_hz=tuple(float(abs(np.angle(z)) / (2 * np.pi * signals.dt)) for z in virtual_mode),
    )
    return NSIResult(
        candidate=cand,
        model=model,
        singular_values=singular_values,
        order=order,
        block_rows=int(block_rows),
        input_dofs=tuple(signals.input_dofs),
        output_dofs=tuple(signals.output_dofs),
        band_hz=(float(band[0]), float(band[1])),
        modes=tuple(modes),
        spurious_poles=spurious,
        coefficients=_coefficients(model, signals, cand.terms, band, weighting),
        options=resolved,
        fit=fit,
        rigid_body_poles=rigid,
    )


def informed_modes(modes, signals) -> tuple[list, list]:
    """The modes the data can inform, and those below the band integrated sensors were integrated in.

    A record integrated from accelerometers or velocity sensors in time holds no motion below the
    integration window's lower edge ``f_lo (1 - taper)`` (:attr:`Signals.acceleration_noise`); a "mode"
    the subspace step places there (a simulated swept-sine beam: 1.6 Hz with ζ = 0.99, integration from 8 Hz)
    fits nothing the structure did, and it set the default averaging band of λ below the data. So does
    a heavily damped one (ζ > :data:`INTEGRATION_ARTEFACT_DAMPING`) whose half-power band
    ``f (1 - ζ)`` starts below ``f_lo``: the integrated noise, largest at the band's lower edge.

    Parameters
    ----------
    modes : list of Mode
    signals : Signals
        The measured signals (with their integration recipe when integrated in time).

    Returns
    -------
    kept, below : list of Mode
        All modes are kept when none would remain.
    """
    from ..noise import acceleration_noise_of

    noise = acceleration_noise_of(signals)
    if noise is None:
        return list(modes), []
    corner = float(noise.band_hz[0])
    floor = corner * (1.0 - float(noise.taper) if noise.method == "frequency" else 0.5)

    # a heavily damped "mode" whose half-power band reaches below the corner is the integration's
    # low-frequency noise (a record integrated from 1 Hz: 1.33-1.41 Hz with ζ 0.42-0.45 at order 10)
    informed = [m.frequency_hz >= floor and not (m.damping_ratio > INTEGRATION_ARTEFACT_DAMPING
                                                 and m.frequency_hz * (1.0 - m.damping_ratio) < corner)
                for m in modes]
    kept = [m for m, ok in zip(modes, informed) if ok]
    return (kept, [m for m, ok in zip(modes, informed) if not ok]) if kept else (list(modes), [])


INTEGRATION_ARTEFACT_DAMPING = 0.2
"""Damping ratio above which a mode whose half-power band starts below the integration band's lower edge
is set aside as integration noise (:func:`informed_modes`)."""


def _free_body_failure(eigenvalues, dt: float, n_samples: int, colocated: bool = False) -> bool:
    """A rigid-body pole where the model would otherwise fail (unstable, or no physical mode).

    Models that identify without it (an oscillatory structure with a slow real pole) are left alone.
    A model with no physical mode whose poles are all real and stable counts too when a DOF is
    forced and measured (``colocated``): a free body with friction to ground, whose s = 0 pole the
    estimate moved onto the real axis (a carriage with a v|v| candidate: s = -2.3 and -8.6 rad/s,
    which failed with "no physical mode").
    """
    z = np.asarray(eigenvalues, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        poles = np.log(z) / dt
    no_mode = not split_poles(poles, dt)[0]
    if not len(rigid_body_poles(eigenvalues, dt, n_samples)):
        real_stable = bool(np.all((np.abs(z.imag) <= 1e-9 * np.abs(z)) & (z.real > 0) & (np.abs(z) < 1.0)))
        return colocated and no_mode and real_stable
    return bool(np.max(np.abs(eigenvalues)) >= 1.0 or no_mode)


def _fixed_stiffness(options: NSIOptions) -> float:
    """The virtual stiffness to apply now: the given number, 0 for "auto" (decided after a first try)."""
    return 0.0 if options.virtual_stiffness == "auto" else float(options.virtual_stiffness)


def _as_options(options) -> NSIOptions:
    """``options`` or the defaults; InputDataError for anything but NSIOptions (e.g. a dict)."""
    if options is None:
        return NSIOptions()
    if not isinstance(options, NSIOptions):
        raise InputDataError(
            f"identify() takes its settings as NSIOptions, got {type(options).__name__}; "
            "build them with bayesnsi.NSIOptions(block_rows=..., order=...)"
        )
    return options


def _model_order(options: NSIOptions, singular_values: np.ndarray, block_rows: int, n_out: int) -> int:
    """The requested order, or the one at the largest singular-value gap for "auto"."""
    order = options.order
    limit = block_rows * n_out - 1
    if order == "auto":
        return auto_order(singular_values, min(limit, options.max_order))
    if not isinstance(order, (int, np.integer)) or not 1 <= order <= limit:
        raise OrderError(
            f"order {order!r} is impossible with {block_rows} block rows and {n_out} outputs "
            f"(1 ≤ n ≤ {limit}); lower the order or raise block_rows"
        )
    return int(order)


def _input_output_matrices(options: NSIOptions, data, A, C_s, stack, signals: Signals, terms, noise_std):
    """B, C, D in physical units by the chosen estimator, A fixed (see :func:`identify`)."""
    u, y, u_scale, y_scale = stack.u, stack.y, stack.u_scale, stack.y_scale
    zero_feedthrough = options.zero_feedthrough
    C = C_s * y_scale[:, None]
    if options.bd_method == "robust":
        B_s, D_s = _subspace.input_matrices_robust(data, A, C_s, zero_feedthrough)
        return B_s / u_scale, C, D_s * y_scale[:, None] / u_scale
    if options.bd_method == "prediction-error":
        common = dict(noise_std=noise_std, velocity_method=options.velocity_method, output_weights=y_scale**-2.0)
        if options.c_method == "prediction-error":
            B, C, D, _, _ = refine_prediction_error_bc(
                A, C, u, y, signals.dt, signals, terms, zero_feedthrough, **common
            )
            return B, C, D
        B, D, _, _ = refine_prediction_error(A, C, u, y, signals.dt, signals, terms, zero_feedthrough, **common)
        return B, C, D
    B, D, _ = refine_output_error(A, C, u, y, signals.dt, zero_feedthrough, output_weights=y_scale**-2.0)
    return B, C, D


def _coefficients(model: StateSpaceModel, signals: Signals, terms, band, weighting=None
                  ) -> tuple[CoefficientEstimate, ...]:
    """λ_i as the band mean of Re λ_i(ω), with its imaginary ratio and spread (docs/method.md §4).

    ``weighting`` (:func:`._line_information.band_weighting`) weighs the mean by where the data
    inform λ_i(ω); None: the plain mean.
    """
    if not terms:
        return ()
    freqs = np.linspace(band[0], band[1], _BAND_POINTS)
    frf = model.frf(freqs)
    spectrum = coefficient_spectrum(frf, signals.input_dofs, signals.output_dofs, terms)
    constant = [t.expr.is_constant for t in terms]
    if any(constant):  # a constant force acts at DC: its coefficient is read there
        at_dc = coefficient_spectrum(model.frf([0.0]), signals.input_dofs, signals.output_dofs, terms)
        spectrum[:, constant] = at_dc[:, constant]
    weights = None if weighting is None else weighting(frf, freqs, len(signals.input_dofs), model.dt)
    if weights is not None:
        weights[:, constant] = 1.0  # one value over the band: any weights give it
    return band_coefficients(spectrum, terms, band, weights)
