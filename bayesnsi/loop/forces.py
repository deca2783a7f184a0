"""The residual of a model seen as a force at one location (docs/method.md §7, step 5).

A restoring-force-surface view of what a model lacks: the open-loop residual ``r = y - ŷ``
(docs/method.md §5) is mapped, frequency by frequency, to the one force ``f`` at the effect's location
that best explains it through the identified underlying linear FRF of that location,

    F(ω) = h(ω)ᴴ R(ω) / (h(ω)ᴴ h(ω) + ε),

where ``h(ω)`` is the FRF from a unit force at the location (+ at j, - at k for an element
between DOFs j and k) to the measured outputs and ``ε`` a small Tikhonov load (relative 1e-3 of
the largest ``|h|²``) that keeps frequencies the location barely drives from amplifying noise;
the restoring force is ``-f`` (an effect acts on the structure as ``-λ n``, paper Eq. 5).
Plotted against the displacement and velocity at the location, the residual force of the model
*before* an effect was added holds what that model could not absorb into its linear part; *after*,
it should be a structureless cloud about zero, and the effect's force plus that residual (a
component-plus-residual view) should scatter about the effect's curve. The added effect's force
``λ n(x, v)`` is passed through the same filter so that the curves compare like with like.

``h`` comes from the enlarged model: the extended FRF column of the added term's input ``-n`` is
``λ h`` (paper Eq. 8), so ``h = H_E[:, m + i] / λ_i``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ResidualForce", "residual_force"]

_LOAD = 1e-3


@dataclass(frozen=True)
class ResidualForce:
    """Residual force at an effect's location before and after the effect was added.

    Attributes
    ----------
    location : tuple of int
        ``(k,)`` or ``(j, k)``.
    displacement, velocity : ndarray, shape (N,)
        At the location (relative, ``x_j - x_k``, for an element).
    before, after : ndarray, shape (N,)
        Restoring force equivalent to the open-loop residual of the model without / with the
        effect, in the units of the measured force (minus the force that would produce the
        residual: the effect acts on the structure as ``-λ n``).
    effect : ndarray, shape (N,)
        The added effect's force ``λ n(x, v)`` through the same filter.
    """

    location: tuple[int, ...]
    displacement: np.ndarray
    velocity: np.ndarray
    before: np.ndarray
    after: np.ndarray
    effect: np.ndarray

    @property
    def component_plus_residual(self) -> np.ndarray:
        """``effect + after``: the force the data hold at the location according to the enlarged
        model (the regression diagnostic of that name): it scatters about ``effect`` when the
        effect's form is right."""
        return self.effect + self.after


def _equivalent_force(h: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """Least-squares force per frequency; ``h`` (n_freq, l), ``residual`` (N, l) -> (N,)."""
    spectrum = np.fft.rfft(residual, axis=0)
    power = np.sum(np.abs(h) ** 2, axis=1)
    load = _LOAD * power.max()
    force = np.sum(h.conj() * spectrum, axis=1) / (power + load)
    return np.fft.irfft(force, n=len(residual))


def residual_force(before, after, signals, term) -> ResidualForce:
    """The residual of ``before`` and of ``after`` as forces at ``term``'s location (module notes).

    Parameters
    ----------
    before, after : NSIResult
        The model without and with ``term`` (``after.terms`` holds ``term``).
    signals : Signals
        The estimation data both were identified from.
    term : Term
        The added effect.

    Returns
    -------
    ResidualForce
    """
    index = after.terms.index(term)
    column = len(after.input_dofs) + index
    lam = after.coefficients[index].value
    freqs = np.fft.rfftfreq(signals.n_samples, signals.dt)
    # (n_freq, l): unit force at the location, through the model the residuals come from (a free body: the
    # stabilised one, virtual spring on the input; the free FRF's rigid-body 1/ω² set the Tikhonov load)
    h = after.model.frf(freqs)[:, :, column] / lam
    r_before = before.reconstruct(signals).residual
    r_after = after.reconstruct(signals).residual
    x, v = signals.state_rows(term.expr.displacement_dofs, term.expr.velocity_dofs)
    effect = lam * term.evaluate(x, v)
    # forced response of the effect alone through h, then back: the same filter as the residuals
    effect_response = np.fft.irfft(h * np.fft.rfft(effect)[:, None], n=signals.n_samples, axis=0)
    columns = {dof: c for c, dof in enumerate(signals.output_dofs)}
    velocities = signals.velocities()
    at = tuple(term.at)
    displacement = np.array(signals.displacement[:, columns[at[0]]], dtype=float)
    velocity = np.array(velocities[:, columns[at[0]]], dtype=float)
    if len(at) == 2:
        displacement -= signals.displacement[:, columns[at[1]]]
        velocity -= velocities[:, columns[at[1]]]
    return ResidualForce(
        location=at,
        displacement=displacement,
        velocity=velocity,
        before=-_equivalent_force(h, r_before),  # restoring force: the effect acts as -λ n
        after=-_equivalent_force(h, r_after),
        effect=_equivalent_force(h, effect_response),
    )
