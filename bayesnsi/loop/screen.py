"""Cheap screening of candidate effects before they are re-identified (docs/method.md §7, step 3).

Re-identifying the model with every effect of the dictionary costs one NSI run and one
reconstruction per effect. The screen ranks all of them from the data alone, at a small fraction
of that cost, so that only the best few are re-identified and scored by evidence (measurements:
``docs/measurements.md``, closing the loop).

The screen is a frequency-domain regression of the outputs on the extended input
(``Y(ω) = H_E(ω) U(ω)``, paper Eq. 8 in the frequency domain; the nonlinear-feedback idea of
NSI estimated nonparametrically, as in "nonlinear identification through feedback of the
outputs", Adams & Allemang 2000). Over each group of ``group_bins`` adjacent DFT bins the
extended FRF is taken as constant and a constant absorbs the leakage of the record's ends
(the local polynomial method of Pintelon & Schoukens, with degree 0). Nothing is assumed about the
underlying linear model, so an effect that a fixed-pole model would miss because the missing
nonlinearity has already shifted the identified poles is still seen. With the residual power
``RSS_{g,o}`` of group g and output channel o (complex Gaussian errors, a variance per group
and channel, profiled out), the log-likelihood ratio of adding the effect's column ``-n_e`` is

    score_e = Σ_{g,o} (W - P) · log(RSS_{g,o}(without) / RSS_{g,o}(with e)),

W bins and P regressors per group. Its absolute value is no evidence (the errors-in-variables
bias and the local model error enter it): it only orders the effects.

On a periodic record of several whole periods (``signals.period``; per realisation when it holds
several) the regression uses the period's lines only: each column is averaged over the periods of
its realisation before its DFT (the same as keeping the full record's bins at multiples of the
number of periods). Of the full record's bins all but one in M (M periods) hold measurement noise
alone, and an effect's input built from the same noisy outputs fits that noise (the
errors-in-variables bias): on a 4-DOF chain measured by velocity sensors (7 periods, a flat
multisine) ``v_k|v_k|`` fitted about 95 % of output k's noise in each group, and every velocity
effect outranked the missing cubic spring (54th of 75). On the lines, the cubic ranked 2nd. The
lines lie M times farther apart than the record's bins, so a group of them spans M times the
bandwidth, over which a force's FRF no longer stays constant near a resonance: there the local model
lets each force's FRF vary linearly across the group as well (one more regressor per force, the
force's spectrum times a ramp from -1 to 1). Without it the true x1³ of a two-DOF chain (10 periods,
0.1 Hz lines) ranked 16th of 33 and fell out of the re-identified six; with it 1st (the chain above:
the cubic 1st, v1|v1| 5th).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..exceptions import BayesNSIError
from ..noise import period_blocks
from ..nsi import extended_input

if TYPE_CHECKING:
    from ..models.dictionary import Effect

__all__ = ["PLACES_PER_LOCATION", "best_locations_first", "second_widths_last", "screen_effects"]

PLACES_PER_LOCATION = 3
"""Screen places per location on average (:func:`best_locations_first`): the rival stiffness or damping types."""


def _periods(signals) -> tuple[int, int] | None:
    """``(period, realisations)`` of a record with two or more whole periods per realisation; else None."""
    period, realisations = getattr(signals, "period", None), max(int(getattr(signals, "realisations", 1) or 1), 1)
    if not period or signals.n_samples // realisations // int(period) < 2:
        return None
    return int(period), realisations


def _group_spectra(columns: np.ndarray, bins: np.ndarray, n_groups: int, group_bins: int, periods=None) -> np.ndarray:
    """DFT of standardised columns at ``bins``, shape (n_groups, group_bins, n_columns).

    ``periods = (period, R)`` (:func:`_periods`): each of the R realisations averaged over its whole
    periods first (:func:`bayesnsi.nsi.steady.period_blocks`), ``bins`` of the one-period DFT,
    ``n_groups`` per realisation (R × n_groups groups in all).
    """
    columns = columns / columns.std(axis=0)
    if periods is None:
        spectrum = np.fft.rfft(columns, axis=0)[bins]
        return spectrum.reshape(n_groups, group_bins, columns.shape[1])
    period, realisations = periods
    blocks = period_blocks(columns, period, realisations)
    assert blocks is not None  # two or more whole periods per realisation (_periods)
    mean = blocks.reshape(realisations, -1, period, columns.shape[1]).mean(axis=1)  # (R, P, k)
    spectrum = np.fft.rfft(mean, axis=1)[:, bins]
    return spectrum.reshape(realisations * n_groups, group_bins, columns.shape[1])


def second_widths_last(ordered: list[Effect]) -> list[Effect]:
    """Screen order with each location's later smoothed-friction widths moved after every other effect.

    The widths ε of ``tanh(v/ε)`` (:func:`bayesnsi.models.dictionary.default_widths`) are grid points of
    one effect at one location that the loop does not refine: the best ranked one stands for them, and
    its neighbour, which a screen ranks next to it, would take the place of another type (docs/method.md
    §7; measured in docs/measurements.md, the quality index and model error: the two-DOF chain's cubic
    spring missed the places behind a second width of ``tanh(v1/ε)``). A clearance's gaps keep their
    places: each one ranked among the best is a start of the gap's refinement
    (:func:`bayesnsi.loop.scoring.refine_gap`), whose evidence has more than one local maximum (on the
    F-16 the second gap's refinement is the clearance the loop accepts). The relative order of the rest
    is kept.

    Parameters
    ----------
    ordered : list of Effect
        Effects in screen order, best first.

    Returns
    -------
    list of Effect
        The effects but the second and later widths at a location, in screen order, then those.
    """
    seen: set = set()
    first: list[Effect] = []
    later: list[Effect] = []
    for effect in ordered:
        key = tuple(effect.location)
        (later if effect.eps is not None and key in seen else first).append(effect)
        if effect.eps is not None:
            seen.add(key)
    return first + later


def best_locations_first(ordered: list[Effect], count: int, per_location: int = PLACES_PER_LOCATION) -> list[Effect]:
    """Screen order with the effects of the best ``ceil(count / per_location)`` locations first.

    The screen tells locations apart better than types: the types at one location (x|x|, x³ and a
    clearance; v|v|, v³ and a friction) are functions of the same noisy signal, whose errors in
    variables weaken the higher powers' columns more, so their order at 5 % noise is no guide to
    the evidence, while a location without the effect explains little with any type. The places
    therefore go to the rival types at the locations the screen ranks best (ordered by their best
    effect) rather than to one type at every location (docs/method.md §7; measured in
    docs/measurements.md, the quality index and model error). The relative order within the two
    groups is kept.

    Parameters
    ----------
    ordered : list of Effect
        Effects in screen order, best first.
    count : int
        The screen's places (``LoopOptions.screen``).
    per_location : int
        Places per location on average (:data:`PLACES_PER_LOCATION`).

    Returns
    -------
    list of Effect
        The effects at the best locations in screen order, then the others in screen order.
    """
    locations = list(dict.fromkeys(tuple(e.location) for e in ordered if e.shape is None))
    best = set(locations[: max(1, -(-count // per_location))])
    return [e for e in ordered if tuple(e.location) in best] + [e for e in ordered if tuple(e.location) not in best]


def _orthonormal_basis(design: np.ndarray) -> np.ndarray:
    """Orthonormal basis of each group's regressors (reduced QR), shape (n_groups, W, P)."""
    return np.linalg.qr(design, mode="reduced")[0]


def _project_out(basis: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``columns`` minus their projection on each group's ``basis`` (shapes (G, W, P), (G, W, k))."""
    return columns - basis @ (basis.conj().transpose(0, 2, 1) @ columns)


def screen_effects(
    signals,
    candidate,
    effects,
    *,
    max_frequency_hz: float | None = None,
    group_bins: int = 8,
    velocity_method: str = "fourth",
) -> list[tuple[Effect, float]]:
    """Rank effects by how much of the outputs their nonlinear input explains (see module notes).

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidate : CandidateModel
        The current model; its terms are regressors of every group.
    effects : list of Effect
        Effects to rank (those already in ``candidate`` are skipped).
    max_frequency_hz : float, optional
        Highest frequency used (default: the Nyquist frequency). Above the structure's modes the
        outputs are mostly measurement noise, which the effects' inputs (built from the same
        noisy outputs) fit spuriously: :func:`bayesnsi.loop.close_the_loop` passes 1.6 × the
        highest identified natural frequency.
    group_bins : int
        W, adjacent DFT bins over which the extended FRF is taken as constant.
    velocity_method : str
        Differentiator when the signals carry no velocities.

    Returns
    -------
    list of (Effect, float)
        Each effect with its score, best first; ``-inf`` for an effect whose input cannot be
        built (unmeasured DOF, NaN or constant on the data).

    Raises
    ------
    BayesNSIError
        When the record is too short for one group of ``group_bins`` bins, or the current model's
        own extended input cannot be built.
    """
    present = {t.name for t in candidate.terms}
    effects = [effect for effect in effects if effect.term.name not in present]
    base = extended_input(signals, candidate.terms, velocity_method, input_hold="sample")
    periods = _periods(signals)  # periodic: the period's lines only (module notes)
    freqs = np.fft.rfftfreq(signals.n_samples if periods is None else periods[0], signals.dt)
    top = signals.fs / 2 if max_frequency_hz is None else min(float(max_frequency_hz), signals.fs / 2)
    bins = np.nonzero((freqs > 0) & (freqs <= top))[0]
    n_groups = len(bins) // group_bins
    n_forces = signals.force.shape[1]
    # inputs, the effect, the leakage constant; on the period's lines each force's FRF also varies linearly over a
    # group (module notes)
    size = base.shape[1] + 2 + (n_forces if periods is not None else 0)
    if n_groups < 1 or group_bins <= size:
        kind = "DFT bins" if periods is None else "lines of the period"
        raise BayesNSIError(
            f"the record has {len(bins)} {kind} up to {top:g} Hz: too few to screen effects in groups of "
            f"{group_bins} bins with {size} regressors; score every effect instead (screen=None)"
        )
    bins = bins[: n_groups * group_bins]
    outputs = _group_spectra(np.asarray(signals.displacement, dtype=float), bins, n_groups, group_bins, periods)
    inputs = _group_spectra(base, bins, n_groups, group_bins, periods)
    leakage = np.ones((inputs.shape[0], group_bins, 1), dtype=complex)
    regressors = [inputs, leakage]
    if periods is not None:
        regressors.append(np.linspace(-1.0, 1.0, group_bins)[None, :, None] * inputs[:, :, :n_forces])
    basis = _orthonormal_basis(np.concatenate(regressors, axis=2))
    residual = _project_out(basis, outputs)  # of the current model's regression
    residual_power = np.maximum((np.abs(residual) ** 2).sum(axis=1), np.finfo(float).tiny)  # (G, l)
    x, v = signals.state_arrays(velocity_method=velocity_method)
    n_dofs = x.shape[0]
    scored = []
    for effect in effects:
        term, value = effect.term, None
        if max(term.expr.dofs, default=0) <= n_dofs:
            with np.errstate(all="ignore"):
                value = -term.evaluate(x, v)
        if value is None or not np.all(np.isfinite(value)) or not np.std(value) > 0:
            scored.append((effect, -np.inf))
            continue
        # Adding one regressor e: RSS_with = RSS_without - |<ẽ, r>|² / |ẽ|², ẽ = e projected out.
        new = _project_out(basis, _group_spectra(value[:, None], bins, n_groups, group_bins, periods))[:, :, 0]
        new_power = (np.abs(new) ** 2).sum(axis=1)  # (G,)
        projection = np.abs(np.einsum("gw,gwo->go", new.conj(), residual)) ** 2
        explained = projection / np.maximum(new_power, np.finfo(float).tiny)[:, None]
        fraction = np.clip(explained / residual_power, 0.0, 1.0 - 1e-12)
        score = -(group_bins - size) * float(np.sum(np.log1p(-fraction)))
        scored.append((effect, score))
    order = sorted(range(len(scored)), key=lambda k: -scored[k][1])  # stable: ties in dictionary order
    return [scored[k] for k in order]
