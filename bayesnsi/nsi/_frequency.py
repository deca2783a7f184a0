"""The frequency route of :func:`bayesnsi.nsi.identify` (``NSIOptions.domain = "frequency"``; docs/method.md §11).

Frequency-domain NSI (FNSI, Noël and Kerschen 2013) on a periodic record: the extended input
``[F; -N]`` and the outputs averaged over the periods, fitted on the excited lines inside
``band_hz`` (:mod:`._fnsi`). It returns the same :class:`NSIResult` as the time route, a discrete
model at the data's sampling, so modes, the extended FRF, λ(ω), reconstruction and the evidence
work unchanged. The linear model is refined from several subspace starts, the basis functions are
evaluated again on the model's output when the fit reaches the noise level, and the quality index
is weighted by where the data inform λ(ω) (docs/method.md §11).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import scipy.linalg

from .._fingerprint import signals_fingerprint
from ..exceptions import BayesNSIError, BayesNSIWarning, OrderError, SpuriousPoleWarning, UnstableModelError
from ..models import CandidateModel
from ..options import NSIOptions
from ..signals import Signals
from . import _fnsi
from ._modal_fit import DAMPING_RANGE
from ._stabilised import stabilised_order, stable_modes
from .order import auto_order
from .periodic import best_linear_approximation
from .physics import CoefficientEstimate, band_coefficients, coefficient_spectrum, default_band, split_poles
from .result import IdentificationFit, NSIResult
from .statespace import StateSpaceModel

_BAND_POINTS = 512


def identify_frequency(signals: Signals, cand, options: NSIOptions, start=None) -> NSIResult:
    """Identify ``cand`` from periodic ``signals`` by frequency-domain subspace (see module doc).

    Parameters
    ----------
    signals : Signals
        With ``period`` set; every whole period is used (drop a transient with ``segment``); with
        several ``realisations`` their lines are stacked into one estimate (:func:`._fnsi.line_data`).
    cand : CandidateModel
    options : NSIOptions
        ``block_rows`` (r, block rows of the frequency-domain data matrices; lowered to
        ``M/(m+q+l)`` for M lines; for the linear model at a given order also 1.25, 1.5 and 2 r
        within that bound, each start refined and the lowest weighted misfit kept, since the
        refinement of a many-mode model ends in the local minimum its start leads to; the
        candidates with terms are refined from that model too), ``order``,
        ``max_order``, ``band_hz`` (fitted lines and λ band), ``zero_feedthrough``,
        ``velocity_method`` (only when the basis needs velocities and none are measured:
        spectral differentiation is used instead, exact for periodic data).
    start : NSIResult, optional
        A frequency-route result at the same order with as many terms (the same candidate, or one whose
        terms differ in their parameters): refined from its continuous model alone (:func:`_local_start`),
        no subspace starts and no warm start.

    Returns
    -------
    NSIResult
    """
    data = _fnsi.line_data(signals, cand.terms, options.velocity_method, options.band_hz)
    n_out = signals.displacement.shape[1]
    excited = data.excited_only()  # the subspace step; B, D and the refinement use every band line
    points, omega0 = _fnsi.bilinear_points(excited.freqs_hz)
    # r(m+q+l) real rows against 2M columns: at most half of them, so that the projection off the
    # inputs keeps room for the outputs (at the bound the fit fails: k3 24x off on 74 lines)
    cap = len(excited.lines) // (data.inputs.shape[1] + n_out)
    block_rows = min(int(options.block_rows), cap)
    zf = options.zero_feedthrough
    decompositions = {block_rows: _fnsi.subspace(excited, block_rows, points)}
    left, values, (_, y_scale) = decompositions[block_rows]
    modes_found: tuple = ()
    if options.order == "auto":
        order, modes_found = _auto_order(options, left, values, n_out, y_scale, omega0, block_rows, data)
    else:
        order = _order(options, values, n_out, block_rows)
    local = _local_start(start, cand, order)
    if local is not None:  # a local re-identification from a neighbouring record's model
        Ac0, C0 = local
        refined = _fnsi.refine(data, Ac0, C0, zf)
        return _result(signals, cand, options, data, excited, refined, (block_rows, values, order, Ac0[:0]))
    starts = [block_rows]
    if not cand.terms:  # the linear model: every candidate is refined from it too
        starts += [r for r in (int(1.25 * block_rows), int(1.5 * block_rows), 2 * block_rows)
                   if r <= cap and order <= r * n_out - 1]
    best: tuple | None = None
    for rows in dict.fromkeys(starts):
        if rows not in decompositions:
            decompositions[rows] = _fnsi.subspace(excited, rows, points)
        left, values, (_, y_scale) = decompositions[rows]
        Ac, C = _fnsi.continuous_ac(*_fnsi.system_ac(left, order, n_out, y_scale), omega0)
        Ac, poles = _fnsi.stabilise_continuous(Ac)
        refined = _fnsi.refine(data, Ac, C, zf)
        cost = float(np.sum(np.abs(refined[2][2]) ** 2))
        if best is None or cost < best[0]:
            best = (cost, rows, values, order, poles, refined)
    assert best is not None  # starts is never empty
    _, block_rows, singular_values, order, reflected, refined = best
    refined = _better_of_warm_start(signals, cand, options, data, refined)
    return _result(signals, cand, options, data, excited, refined, (block_rows, singular_values, order, reflected),
                   modes_found)


def _local_start(start, cand, order):
    """The continuous ``(A_c, C)`` of ``start``: a frequency-route result at ``order`` with as many terms as ``cand``.

    Its terms may differ from ``cand``'s in their parameters (a neighbouring shape or gap of one effect): B and
    D are solved again on the lines for ``cand``'s basis, A and C refined from ``start``'s.
    """
    if (start is None or start.options.domain != "frequency" or start.order != order
            or len(start.terms) != len(cand.terms) or start.virtual_stiffness):
        return None
    model = start.model
    return model.continuous_state_matrix(), np.array(model.C, dtype=float)


def _result(signals: Signals, cand, options: NSIOptions, data, excited, refined, subspace, modes_found=()):
    """The :class:`NSIResult` of a refined continuous model ``(A_c, C, (B_c, D_c, residual))``."""
    zf = options.zero_feedthrough
    block_rows, singular_values, order, reflected = subspace
    order = int(refined[0].shape[0])  # a lone real pole of the start becomes a pair (_modal_fit.modal_start)
    reflected = reflected[reflected.imag >= 0]  # one of each conjugate pair
    Ac, C, fit = refined
    if cand.terms and _at_noise_level(fit[2]):  # the basis again from the model's (less noisy) output
        data = data.with_smoothed_basis(data.outputs - fit[2] * data.output_std)
        Ac, C, fit = _fnsi.refine(data, Ac, C, zf)
    Bc, Dc, residual = fit
    dt = 1.0 / signals.fs
    upsample = int(options.upsample)
    dt_model = dt / upsample  # the stored discrete model; its FRF nears the continuous one as (ωΔt)²
    A = np.real(scipy.linalg.expm(Ac * dt_model))
    if len(reflected):
        named = ", ".join(f"{abs(p.imag) / (2 * np.pi):.3g} Hz (Re s = {p.real:.3g})" for p in reflected)
        warnings.warn(
            f"candidate {cand.name!r}: unstable pole(s) at {named} reflected into the left half-plane "
            f"(fitted lines {data.freqs_hz[0]:.3g}-{data.freqs_hz[-1]:.3g} Hz) before B, D were fitted; the "
            "candidate is kept - check the order if such a pole lies inside the band",
            SpuriousPoleWarning,
            stacklevel=3,
        )
    z_model = np.exp(2j * np.pi * data.freqs_hz * dt_model)
    # the stored discrete model: closest on the lines to the continuous one (not to the data again)
    continuous = dataclasses.replace(data, outputs=data.outputs - residual * data.output_std)
    B, D, _ = _fnsi.input_matrices(continuous, A, C, False, z_model)
    model = StateSpaceModel(A=A, B=B, C=C, D=D, dt=dt_model)
    modes, spurious = split_poles(model.poles, dt_model)
    # a refined pair held at the lowest damping ratio the search allows is no mode: it fits a narrow feature of the
    # lines (distortion, noise); it stays in the model and is reported with the spurious poles
    pinned = [m for m in modes if m.damping_ratio < _PINNED_DAMPING]
    if pinned:
        modes = [m for m in modes if m.damping_ratio >= _PINNED_DAMPING]
        spurious = np.concatenate([spurious, [m.pole for m in pinned], [np.conj(m.pole) for m in pinned]])
    if not modes:
        raise UnstableModelError(
            f"candidate {cand.name!r}: no physical mode among the {order} identified poles; "
            "check the order (singular values) and the band"
        )
    if len(spurious):
        warnings.warn(
            f"candidate {cand.name!r}: {len(spurious)} of {order} poles discarded as non-physical "
            "(real or with damping outside (0, 1)); see NSIResult.spurious_poles",
            SpuriousPoleWarning,
            stacklevel=3,
        )
    fit_band = (float(data.freqs_hz[0]), float(data.freqs_hz[-1]))
    band = tuple(float(b) for b in (options.band_hz or default_band(modes, signals.fs)))
    _WARM[_warm_key(signals, cand.terms, options)] = (Ac.copy(), C.copy())  # copies: the model may share them
    while len(_WARM) > _WARM_SIZE:
        _WARM.pop(next(iter(_WARM)))
    resolved = options.replace(
        block_rows=block_rows, order=order, band_hz=band, input_hold="sample", upsample=upsample, virtual_stiffness=0.0,
    )
    unexcited = _unexcited_ratio(signals)
    fit = IdentificationFit(
        n_samples=int(signals.n_samples), fs=signals.fs,
        reflected_poles_hz=tuple(float(abs(p.imag) / (2 * np.pi)) for p in reflected),
        fit_band_hz=fit_band, requested_block_rows=int(options.block_rows),
        period=int(signals.period or 0), n_periods=int(data.n_periods),
        n_realisations=int(data.n_realisations),  # their lines stacked: each count below is per realisation
        n_lines=int(len(excited.lines) // data.n_realisations),
        n_band_lines=int(len(data.lines) // data.n_realisations),
        stable_modes_hz=tuple(round(m.frequency_hz, 6) for m in modes_found),  # order "auto": stabilisation diagram
        line_misfit=float(np.sqrt(np.mean(np.abs(residual if data.excited is None else residual[data.excited]) ** 2))),
        band_misfit=float(np.sqrt(np.mean(np.abs(residual) ** 2))),  # the unexcited band lines included
        unexcited_ratio=None if unexcited is None else tuple((k, tuple(v)) for k, v in unexcited.items()),
    )
    return NSIResult(
        candidate=cand,
        model=model,
        singular_values=singular_values,
        order=order,
        block_rows=block_rows,
        input_dofs=tuple(signals.input_dofs),
        output_dofs=tuple(signals.output_dofs),
        band_hz=(float(band[0]), float(band[1])),
        modes=tuple(modes),
        spurious_poles=spurious,
        coefficients=_coefficients(Ac, Bc, C, Dc, signals, cand.terms, band, data),
        options=resolved,
        fit=fit,
    )


_PINNED_DAMPING = 1.5 * DAMPING_RANGE[0]  # damping ratios this close to the refinement's bound are no modes
_NOISE_FIT = 1.5  # a weighted line misfit below this many times the number of complex residuals is at noise level
_WARM: dict = {}  # (data, terms, settings) -> refined continuous (A_c, C) of identified candidates
_WARM_SIZE = 64


def _warm_key(signals: Signals, terms, options: NSIOptions) -> tuple:
    settings = (options.order, options.block_rows, options.band_hz, options.zero_feedthrough, options.velocity_method)
    return signals_fingerprint(signals), tuple(t.name for t in terms), repr(settings)


def _at_noise_level(residual: np.ndarray) -> bool:
    """The weighted misfit on the lines is at most ``_NOISE_FIT`` per complex residual."""
    return float(np.sum(np.abs(residual) ** 2)) <= _NOISE_FIT * residual.size


def _better_of_warm_start(signals: Signals, cand, options: NSIOptions, data, fitted):
    """``fitted`` (A_c, C, its B, D fit), or the refinement started from the poles of ``cand`` without
    its last term (the same triple, :func:`._fnsi.refine`).

    A candidate with one more term than a model identified before on the same data and settings
    (the loop's current model) is also refined from that model's A_c, C: there, B and D gain one
    column, so the weighted misfit on the lines can only fall. The extended-input subspace
    estimate alone may start the refinement in a worse local minimum, which makes the ranking of
    effects flat or wrong (docs/method.md §11: A, C re-estimated and refined for every candidate).
    The lower weighted misfit wins. Not tried when ``fitted`` already fits the lines to the noise
    level (weighted misfit below ``_NOISE_FIT`` per complex residual): no start can gain there.
    The smaller model is identified first when it was not (cached per data and settings), so the
    result does not depend on what was identified before (up to the refinement's tolerance along
    poorly determined directions).
    """
    if not cand.terms or _at_noise_level(fitted[2][2]):
        return fitted
    key = _warm_key(signals, cand.terms[:-1], options)
    if key not in _WARM:  # identify the smaller model first: the result never depends on what ran before
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                identify_frequency(signals, CandidateModel(name="warm start", terms=tuple(cand.terms[:-1])), options)
        except (BayesNSIError, np.linalg.LinAlgError):
            return fitted
    start = _WARM.get(key)
    if start is None or start[0].shape != fitted[0].shape or start[1].shape != fitted[1].shape:
        return fitted
    warm = _fnsi.refine(data, start[0].copy(), start[1].copy(), options.zero_feedthrough)
    return warm if np.sum(np.abs(warm[2][2]) ** 2) < np.sum(np.abs(fitted[2][2]) ** 2) else fitted


def _unexcited_ratio(signals: Signals) -> dict | None:
    """Median output power over its noise level at the unexcited odd / even lines (≈ 1: no distortion).

    None with several forces or no unexcited line between the excited ones (a full multisine).
    """
    if signals.force.shape[1] != 1:
        return None
    ratios = best_linear_approximation(signals.realisation_records()).unexcited_ratio()
    out = {k: [float(x) for x in v] for k, v in ratios.items() if np.all(np.isfinite(v))}
    return out or None


def _auto_order(options: NSIOptions, left, singular_values, n_out: int, y_scale, omega0: float, block_rows: int,
                data) -> tuple[int, tuple]:
    """``order = "auto"`` on the frequency route: the stable modes of the band (:mod:`._stabilised`).

    The subspace models of orders 2, 4, ... up to ``max_order`` (and the block rows' bound) are
    read as a stabilisation diagram inside the fitted lines' band; the order is twice the number
    of stable modes plus the residual pairs. Where no mode is stable (too few lines, or a record
    of noise) the largest gap of the singular values decides, as on the time route.
    """
    limit = min(block_rows * n_out - 1, int(options.max_order))
    band = (float(data.freqs_hz.min()), float(data.freqs_hz.max()))

    def poles_at(n):
        Ac, C = _fnsi.continuous_ac(*_fnsi.system_ac(left, n, n_out, y_scale), omega0)
        lam, vec = np.linalg.eig(Ac)
        return lam, C @ vec

    modes = stable_modes(poles_at, range(2, limit + 1, 2), band)
    if not modes:
        return auto_order(singular_values, limit), ()
    return stabilised_order(modes, limit), modes


def _order(options: NSIOptions, singular_values: np.ndarray, n_out: int, block_rows: int) -> int:
    limit = block_rows * n_out - 1
    if options.order == "auto":
        return auto_order(singular_values, min(limit, options.max_order))
    if not 1 <= int(options.order) <= limit:
        raise OrderError(
            f"order {options.order!r} is impossible with {block_rows} block rows (at most {options.block_rows}; "
            f"fewer when the band holds few lines) and {n_out} outputs (1 ≤ n ≤ {limit}); lower the order, "
            "or widen the band"
        )
    return int(options.order)


def _coefficients(Ac, Bc, Cc, Dc, signals: Signals, terms, band, data) -> tuple[CoefficientEstimate, ...]:
    """λ_i as the band mean of Re λ_i(ω) of the continuous model (docs/method.md §4), with its quality
    index weighted by where the data inform λ_i(ω) (docs/method.md §11).

    The index is ``Σ_k w_k |Im λ_i(ω_k)| / |Σ_k w_k Re λ_i(ω_k)|`` over the fitted lines ``k`` of the
    band, with ``w_k`` the power of the term's contribution to the outputs over the output noise at
    that line, ``Σ_o |H_E[o, m+i](ω_k) N_i(k)|² / σ_o²(k)``: to first order the inverse relative
    variance of λ_i(ω_k). Lines where the basis function carries no power are uninformative and do
    not decide the index (on the simulated GVT at 1 N, λ(ω) of the true friction term has
    |Im|/|Re| ≈ 0.27 below 4 Hz, where its contribution is ≈ 2 % of the total, and 0.05-0.08 above
    6 Hz). The value stays the plain band mean of Re λ_i(ω).
    """
    if not terms:
        return ()
    freqs = np.linspace(band[0], band[1], _BAND_POINTS)
    spectrum = coefficient_spectrum(_frf(Ac, Bc, Cc, Dc, freqs), signals.input_dofs, signals.output_dofs, terms)
    plain = band_coefficients(spectrum, terms, band)
    inside = (data.freqs_hz >= band[0]) & (data.freqs_hz <= band[1])
    if np.count_nonzero(inside) < 2:
        return plain
    frf = _frf(Ac, Bc, Cc, Dc, data.freqs_hz[inside])
    lam = coefficient_spectrum(frf, signals.input_dofs, signals.output_dofs, terms)
    m = len(signals.input_dofs)
    contribution = frf[:, :, m:] * data.inputs[inside][:, None, m:]  # (line, output, term)
    info = np.sum(np.abs(contribution) ** 2 / data.output_std[inside][:, :, None] ** 2, axis=1)
    out = []
    for k, est in enumerate(plain):
        w, lam_k = info[:, k], lam[:, k]
        ok = np.isfinite(lam_k) & np.isfinite(w)
        mean_re = abs(float(np.sum(w[ok] * lam_k[ok].real)))
        if not ok.any() or mean_re == 0.0:
            out.append(est)
            continue
        ratio = float(np.sum(w[ok] * np.abs(lam_k[ok].imag))) / mean_re
        out.append(dataclasses.replace(est, imag_ratio=ratio))
    return tuple(out)


def _frf(Ac, Bc, Cc, Dc, freqs) -> np.ndarray:
    """Extended FRF of the continuous model at ``freqs`` [Hz], shape (n_freq, l, m + q)."""
    lam, vec = np.linalg.eig(Ac)
    resolvent = 1.0 / (2j * np.pi * freqs[:, None] - lam[None])
    return np.einsum("on,fn,ni->foi", Cc @ vec, resolvent, np.linalg.solve(vec, Bc)) + Dc[None]
