"""Free bodies: rigid-body poles, a known stabilising spring, physical parameters (docs/method.md §11).

A structure without a spring to ground (a carriage on a guide, a free-free test article) has a
rigid-body pole at s = 0, z = 1. Its identified A then lies on (or, by noise, just outside) the
unit circle and the extended FRF is ``1/(-Mω² + jωC)``. The route taken here is a **known
stabilising term**: a virtual spring ``k·x_p`` is added at every DOF p that is both forced and
measured, on both sides of the equation of motion::

    M ẍ + C ẋ + (K + k) x + Σ λ_i l_i n_i = f + k x_measured      (input u = f + k·x)

The identified model from ``u`` to ``x`` then has an oscillatory mode near ``√(k/M)`` and is
stable; the known spring is removed again afterwards:

- the free model's state matrix is ``A + k B_f S C`` (the spring fed back through the model),
  whose eigenvalues are the physical poles (the rigid-body pole at z ≈ 1 among them);
- the free FRF is ``H = H_k (I - k S H_k)⁻¹`` on the forced, measured DOFs;
- λ_i(ω) are unchanged (numerator and denominator FRF share the spring).

Open-loop simulation of a free body over a long record drifts (the rigid-body mode integrates
every error); the error used for such systems is the force predicted from the measured motion
(the inverse, IDIM view) against the measured force, and simulation over a short horizon
(:mod:`bayesnsi.nsi.inverse`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import NotIdentifiableError
from ..signals import Signals
from .statespace import StateSpaceModel

__all__ = [
    "PhysicalParameters",
    "auto_stiffness",
    "free_frf",
    "free_model",
    "is_free_body",
    "physical_parameters",
    "rigid_body_poles",
    "stabilise",
]


@dataclass(frozen=True)
class PhysicalParameters:
    """Lumped parameters at one forced, measured DOF from the identified (free) FRF.

    Attributes
    ----------
    dof : int
    mass : float
        M [kg] (force / acceleration).
    damping : float
        Viscous damping C [N s/m].
    stiffness : float
        K [N/m] (≈ 0 for a free body).
    band_hz : (float, float)
        Band of the least-squares fit of ``1/H(ω) = K - Mω² + jωC``.
    """

    dof: int
    mass: float
    damping: float
    stiffness: float
    band_hz: tuple[float, float]


def _shared(signals_or_dofs) -> list[tuple[int, int]]:
    """(input column, output column) of each DOF that is both forced and measured."""
    inputs, outputs = signals_or_dofs
    return [(j, list(outputs).index(d)) for j, d in enumerate(inputs) if d in outputs]


def auto_stiffness(signals: Signals) -> float:
    """The virtual stiffness chosen for ``virtual_stiffness = "auto"`` [N/m].

    ``k = std(f_p)/std(x_p)`` averaged over the forced, measured DOFs p: the spring force is
    comparable to the measured force, so the added mode sits where the record has motion.

    Parameters
    ----------
    signals : Signals
        Measured forces and displacements.

    Returns
    -------
    float

    Raises
    ------
    NotIdentifiableError
        When no DOF is both forced and measured.
    """
    pairs = _shared((signals.input_dofs, signals.output_dofs))
    if not pairs:
        raise NotIdentifiableError(
            "a rigid-body pole (z = 1) was found, but no DOF is both forced and measured, so no "
            "stabilising spring can be placed; measure the response at a forced DOF"
        )
    force, disp = np.asarray(signals.force), np.asarray(signals.displacement)
    ratios = [np.std(force[:, j]) / np.std(disp[:, i]) for j, i in pairs]
    return float(np.mean(ratios))


def stabilise(signals: Signals, stiffness: float) -> Signals:
    """The signals with the known spring moved to the input: ``f_p + k·x_p`` at forced, measured p.

    Parameters
    ----------
    signals : Signals
        Measured forces and displacements.
    stiffness : float
        k [N/m]; 0 returns ``signals`` unchanged.

    Returns
    -------
    Signals
    """
    if not stiffness:
        return signals
    force = np.array(signals.force, dtype=float)
    disp = np.asarray(signals.displacement)
    for j, i in _shared((signals.input_dofs, signals.output_dofs)):
        force[:, j] += stiffness * disp[:, i]
    return Signals(
        force=force,
        displacement=signals.displacement,
        fs=signals.fs,
        input_dofs=signals.input_dofs,
        output_dofs=signals.output_dofs,
        velocity=signals.velocity,
        input_names=signals.input_names,
        output_names=signals.output_names,
    )


def rigid_body_poles(poles_discrete, dt: float, n_samples: int, band_hz=None) -> np.ndarray:
    """Continuous-time poles that are rigid-body poles (s ≈ 0, z ≈ 1) on this record.

    A pole counts as rigid when ``|s| < 2π/T`` with ``T`` the record length (the record cannot
    tell it from zero: less than one cycle or one time constant in the record), whether it is real
    or one of a complex pair: a body with no damping to ground has a double pole at s = 0 (position
    and velocity of the rigid-body motion), which the estimate may split into a slow complex pair.
    An eigenvalue on or outside the unit circle that is real and positive counts too (noise moves
    z = 1 either way). With the band the model was fitted on, a pole with ``|s|`` below a tenth of
    its lower edge (``0.1 · 2π f_lo``) counts as well: there ``1/(jω - s)`` differs from ``1/jω`` by
    less than 10 %, so the data in the band cannot tell it from zero either (a carriage with
    friction, 60 s: the rigid-body pole estimated at s = -0.19 rad/s, above 2π/T = 0.105, next to
    its viscous pole at -1.4 rad/s).

    Parameters
    ----------
    poles_discrete : array_like of complex
        Eigenvalues of the discrete A.
    dt : float
        Sampling interval [s].
    n_samples : int
        Record length in samples.
    band_hz : (float, float), optional
        The band the model was fitted on.

    Returns
    -------
    ndarray of complex
        The rigid-body poles s [rad/s].
    """
    z = np.asarray(poles_discrete, dtype=complex)
    with np.errstate(divide="ignore"):
        s = np.log(z) / dt
    limit = max(2 * np.pi / (n_samples * dt), 0.0 if band_hz is None else 0.1 * 2 * np.pi * float(band_hz[0]))
    real = np.abs(z.imag) <= 1e-9 * np.maximum(np.abs(z), 1e-300)
    rigid = (z.real > 0) & ((np.abs(s) < limit) | (real & (np.abs(z) >= 1.0)))
    return s[rigid]


def free_model(model: StateSpaceModel, stiffness: float, input_dofs, output_dofs) -> StateSpaceModel:
    """The identified model with the known spring removed: ``A + k B_f S C`` (the free body).

    Parameters
    ----------
    model : StateSpaceModel
        Identified from the stabilised input ``[f + k x, -n_1, ...]``.
    stiffness : float
        The virtual stiffness k [N/m] (0: ``model`` unchanged).
    input_dofs, output_dofs : sequence of int
        DOFs of the forces and displacements.

    Returns
    -------
    StateSpaceModel
        Driven by the measured forces (and the nonlinear inputs), same B, C, D.
    """
    if not stiffness:
        return model
    feedback = np.zeros((model.B.shape[1], model.C.shape[0]))
    for j, i in _shared((input_dofs, output_dofs)):
        feedback[j, i] = stiffness
    # u = f + k S y, y = C x + D u: solve the algebraic loop when D is not zero
    loop = np.eye(model.C.shape[0]) - model.D @ feedback
    gain = feedback @ np.linalg.solve(loop, model.C)
    return StateSpaceModel(
        A=model.A + model.B @ gain,
        B=model.B + model.B @ feedback @ np.linalg.solve(loop, model.D),
        C=np.linalg.solve(loop, model.C),
        D=np.linalg.solve(loop, model.D),
        dt=model.dt,
    )


def free_frf(extended_frf: np.ndarray, stiffness: float, input_dofs, output_dofs) -> np.ndarray:
    """Extended FRF of the free body from that of the stabilised model.

    Parameters
    ----------
    extended_frf : ndarray of complex, shape (n_freq, l, m + q)
        ``H_E`` of the model identified with the spring on the input.
    stiffness : float
        k [N/m].
    input_dofs, output_dofs : sequence of int

    Returns
    -------
    ndarray of complex, shape (n_freq, l, m + q)
        ``(I - H_E[:, :, :m] k S)⁻¹ H_E``: every column with the spring fed back.
    """
    if not stiffness:
        return extended_frf
    n_freq, n_out, _ = extended_frf.shape
    m = len(input_dofs)
    feedback = np.zeros((m, n_out))
    for j, i in _shared((input_dofs, output_dofs)):
        feedback[j, i] = stiffness
    loop = np.eye(n_out)[None] - extended_frf[:, :, :m] @ feedback[None]
    return np.linalg.solve(loop, extended_frf)


def is_free_body(result) -> bool:
    """Whether ``result`` is a one-DOF free body (identified with a virtual spring; scored on its force).

    Parameters
    ----------
    result : NSIResult

    Returns
    -------
    bool
    """
    return bool(result.virtual_stiffness) and bool(result.physical_parameters)


def physical_parameters(result) -> tuple[PhysicalParameters, ...]:
    """Mass, viscous damping and stiffness of a one-DOF model from its identified FRF.

    Fits ``1/H(ω) = K - Mω² + jωC`` by least squares over the result's band (``H`` the free FRF,
    with any virtual spring removed). Only models with one force and one displacement at the same
    DOF have such parameters; others give an empty tuple.

    Parameters
    ----------
    result : NSIResult
        An identified candidate.

    Returns
    -------
    tuple of PhysicalParameters
    """
    if len(result.input_dofs) != 1 or tuple(result.input_dofs) != tuple(result.output_dofs):
        return ()
    band = tuple(result.band_hz)
    freqs = np.linspace(band[0], band[1], 256)
    omega = 2 * np.pi * freqs
    stiffness = result.virtual_stiffness
    h = free_frf(result.model.frf(freqs), stiffness, result.input_dofs, result.output_dofs)[:, 0, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        dynamic = 1.0 / h
    if not np.all(np.isfinite(dynamic)):
        return ()
    design = np.column_stack([np.ones_like(omega), -(omega**2)])
    (k_fit, m_fit), *_ = np.linalg.lstsq(design, dynamic.real, rcond=None)
    c_fit = float(np.sum(omega * dynamic.imag) / np.sum(omega**2))
    return (PhysicalParameters(int(result.input_dofs[0]), float(m_fit), c_fit, float(k_fit), band),)
