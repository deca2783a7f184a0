"""From the identified model to physics: FRFs, λ_i(ω), modes (docs/method.md §4, Eqs. 24-32)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import NotIdentifiableError
from ..findings import Finding
from ..models import Term
from .statespace import modal_parameters_from_poles

__all__ = [
    "identification_routes",
    "Mode",
    "CoefficientEstimate",
    "coefficient_spectrum",
    "OUTLIER_SCALES",
    "band_coefficients",
    "consistent_lines",
    "EXCLUDED_NOTE_FRACTION",
    "excluded_lines_findings",
    "split_poles",
    "default_band",
]


@dataclass(frozen=True)
class Mode:
    """One identified mode.

    Attributes
    ----------
    frequency_hz : float
        Natural frequency f_n = |s|/2π [Hz].
    damping_ratio : float
        ζ = -Re(s)/|s| [-].
    pole : complex
        Continuous-time pole s [rad/s] (positive imaginary part).
    """

    frequency_hz: float
    damping_ratio: float
    pole: complex


@dataclass(frozen=True)
class CoefficientEstimate:
    """Nonlinear coefficient λ_i from the mean real part of λ_i(ω) over a band (docs/method.md §4).

    Attributes
    ----------
    term : Term
    value : float
        Mean of Re λ_i(ω) over the band (units of force / units of n_i), gross outliers left out
        (:func:`band_coefficients`); weighted by where the data inform λ_i(ω) on the time route
        (``NSIOptions.band_mean``).
    imag_ratio : float
        mean |Im λ_i(ω)| / |mean Re λ_i(ω)| over the same lines (plain means): the quality index
        (small is good).
    band_hz : (float, float)
    spread : float
        Standard deviation of Re λ_i(ω) over the same lines.
    excluded_fraction : float
        Fraction of the band's lines left out as gross outliers (0 for a consistent λ_i(ω)).
    """

    term: Term
    value: float
    imag_ratio: float
    band_hz: tuple[float, float]
    spread: float
    excluded_fraction: float = 0.0


def split_poles(poles: np.ndarray, dt: float | None = None, min_imag_ratio: float = 1e-6):
    """Separate physical modes from spurious poles (docs/method.md §3).

    Physical: complex pole with positive imaginary part and 0 < ζ < 1. Spurious: real poles,
    poles of negative real discrete eigenvalues (``Im s = π/dt`` when ``dt`` is given: they sit
    at the Nyquist frequency and are artefacts of sampling) and ζ ≤ 0 or ζ ≥ 1.

    Parameters
    ----------
    poles : ndarray of complex
        Continuous-time poles [rad/s].
    dt : float, optional
        Sampling interval [s] of the discrete model the poles come from.
    min_imag_ratio : float
        Poles with ``|Im s| <= min_imag_ratio·|s|`` count as real.

    Returns
    -------
    modes : list of Mode
        Sorted by frequency.
    spurious : ndarray of complex
    """
    poles = np.asarray(poles, dtype=complex)
    freqs, zetas = modal_parameters_from_poles(poles)
    modes, spurious = [], []
    for s, f, z in zip(poles, freqs, zetas):
        is_complex = abs(s.imag) > min_imag_ratio * max(abs(s), 1e-300)
        at_nyquist = dt is not None and abs(abs(s.imag) * dt - np.pi) < 1e-9
        if is_complex and not at_nyquist and 0 < z < 1:
            if s.imag > 0:  # one of each conjugate pair
                modes.append(Mode(float(f), float(z), complex(s)))
        else:
            spurious.append(s)
    modes.sort(key=lambda mode: mode.frequency_hz)
    return modes, np.array(spurious, dtype=complex)


def default_band(modes, fs: float) -> tuple[float, float]:
    """Averaging band holding the identified modes, ends excluded (docs/method.md §4 and 10).

    ``[0.5 f_min, f_max]``, clipped to ``(0, 0.45 fs)``: past the last mode λ(ω) is dominated by
    noise. It ended at ``1.1 f_max`` before; on a 12-DOF chain with a clearance (2 % noise, seeds
    0-3) its last 10 % pulled the mean 2-25 % low, with |Im|/|Re| up to 0.67; ending at the
    highest mode the error is within 5 % and |Im|/|Re| at most 0.12, and the two- and three-DOF
    estimates scatter less (docs/measurements.md, "Averaging band").

    Parameters
    ----------
    modes : sequence of Mode
        The identified physical modes.
    fs : float
        Sampling frequency [Hz].

    Returns
    -------
    (float, float)
        Band [Hz].

    Raises
    ------
    NotIdentifiableError
        When there is no mode.
    """
    if not modes:
        raise NotIdentifiableError(
            "no physical mode was identified, so there is no band to average λ(ω) over; "
            "give [nsi] band_hz explicitly or check the model order"
        )
    f = [mode.frequency_hz for mode in modes]
    return 0.5 * min(f), min(max(f), 0.45 * fs)


def coefficient_spectrum(extended_frf, input_dofs, output_dofs, terms) -> np.ndarray:
    """λ_i(ω) from the extended FRF (docs/method.md §4, paper Eqs. 25-32).

    Parameters
    ----------
    extended_frf : ndarray, complex, shape (n_freq, l, m + q)
        ``H_E``: first m columns the underlying linear FRF at the forced DOFs, column m+i
        equals ``H(ω)[O, :] l_i λ_i``.
    input_dofs, output_dofs : sequence of int
    terms : sequence of Term

    Returns
    -------
    ndarray, complex, shape (n_freq, q)

    Notes
    -----
    Direct route when every DOF of ``l_i`` is forced: ``λ_i = H_E[:, m+i] / (H l_i)`` in the
    least-squares sense over outputs. Otherwise reciprocity ``H[p, k] = H[k, p]`` for forced
    DOFs p that are also measured: ``λ_i = H_E[p, m+i] / (l_iᵀ H[:, p])``, least squares over
    such p. If neither applies, the coefficient is not identifiable from the measured channels.
    """
    input_dofs, output_dofs = list(input_dofs), list(output_dofs)
    routes = identification_routes(terms, input_dofs, output_dofs)
    m = len(input_dofs)
    out = np.empty((extended_frf.shape[0], len(terms)), dtype=complex)
    for idx, term in enumerate(terms):
        column = extended_frf[:, :, m + idx]
        signs = [1.0, -1.0][: len(term.at)]
        if routes[idx] == "direct":
            h_loc = sum(s * extended_frf[:, :, input_dofs.index(d)] for s, d in zip(signs, term.at))
            num = np.sum(np.conj(h_loc) * column, axis=1)
            den = np.sum(np.abs(h_loc) ** 2, axis=1)
        else:
            shared = [p for p in input_dofs if p in output_dofs]
            num = np.zeros(extended_frf.shape[0], dtype=complex)
            den = np.zeros(extended_frf.shape[0])
            for p in shared:
                lhs = column[:, output_dofs.index(p)]
                h_kp = sum(
                    s * extended_frf[:, output_dofs.index(d), input_dofs.index(p)] for s, d in zip(signs, term.at)
                )
                num += np.conj(h_kp) * lhs
                den += np.abs(h_kp) ** 2
        with np.errstate(invalid="ignore", divide="ignore"):
            out[:, idx] = num / den
    return out


def identification_routes(terms, input_dofs, output_dofs) -> list[str]:
    """How each coefficient is separated from the extended FRF: "direct" or "reciprocity".

    Parameters
    ----------
    terms : sequence of Term
        The candidate's nonlinear terms.
    input_dofs, output_dofs : sequence of int
        DOFs of the measured forces and responses.

    Returns
    -------
    list of str
        One route per term.

    Raises
    ------
    NotIdentifiableError
        When a term's location is neither forced nor measured together with a DOF that is both
        forced and measured (docs/method.md §4: "say so - do not guess").
    """
    input_dofs, output_dofs = list(input_dofs), list(output_dofs)
    shared = [p for p in input_dofs if p in output_dofs]
    routes = []
    for term in terms:
        if all(d in input_dofs for d in term.at):
            routes.append("direct")
        elif shared and all(d in output_dofs for d in term.at):
            routes.append("reciprocity")
        else:
            missing = [d for d in term.at if d not in output_dofs]
            fix = (f"measure the response at DOF(s) {missing} as well, or move the term" if shared else
                   f"measure the response at a forced DOF too (a driving point: one of {input_dofs}), through which "
                   "reciprocity scales the term's column of the FRF"
                   + (f", and at DOF(s) {missing}" if missing else ""))
            raise NotIdentifiableError(
                f"coefficient of {term.name} cannot be identified: it needs a force measured at "
                f"DOF(s) {list(term.at)}, or a response measured there together with a DOF that is both "
                f"forced and measured (forces at {input_dofs}, responses at {output_dofs}); {fix}"
            )
    return routes


OUTLIER_SCALES = 50.0
"""Lines of Re λ_i(ω) farther than this many robust standard deviations (1.4826 x the median absolute
deviation) from the band median are left out of the band mean (:func:`band_coefficients`). Near a zero of
the transfer function λ_i(ω) is divided by, the ratio of two identified FRFs runs away: on a simulated
10-DOF chain (cubic spring at DOF 4, force at DOF 10, modes 2.5-55 Hz) Re λ(ω) was the true 5e6 to within
4 % below 45 Hz and -2e7 to -1.5e8 over 50-55 Hz, up to 2000 robust sds away, and the plain band mean
read -1.6e6 (|Im|/|Re| 3.7). On the reference cases (two-, three-DOF, twin: seeds 0-2; the undeclared
cases' declared models: seeds 0-1) no line lies beyond it (three-DOF supersets reach 27), so their
estimates are unchanged (docs/measurements.md, "Robust band mean")."""


def consistent_lines(values) -> np.ndarray:
    """Lines of a band's Re λ_i(ω) kept in its mean: finite and within :data:`OUTLIER_SCALES` robust sds.

    Parameters
    ----------
    values : array_like, shape (n_freq,)
        Re λ_i(ω) on the band's grid.

    Returns
    -------
    ndarray of bool, shape (n_freq,)
        All lines where none is finite (the mean is then NaN, as the plain mean).
    """
    values = np.asarray(values, dtype=float)
    finite = np.isfinite(values)
    if not finite.any():
        return np.ones(values.shape, dtype=bool)
    median = float(np.median(values[finite]))
    robust_sd = 1.4826 * float(np.median(np.abs(values[finite] - median)))
    scale = max(robust_sd, 1e-6 * abs(median), np.finfo(float).tiny)  # a constant λ(ω): rounding is no outlier
    with np.errstate(invalid="ignore"):
        return finite & (np.abs(values - median) <= OUTLIER_SCALES * scale)


def band_coefficients(spectrum: np.ndarray, terms, band, weights=None) -> tuple[CoefficientEstimate, ...]:
    """Each term's λ_i as the band mean of Re λ_i(ω), with its quality index (docs/method.md §4).

    The mean and the index are taken over the lines :func:`consistent_lines` keeps: all of them for a
    consistent λ_i(ω); the lines where it runs away (near a zero of the transfer function it is divided
    by) are left out and counted in ``excluded_fraction``. With ``weights`` the value is the weighted
    mean of Re λ_i(ω) over those lines (the information-weighted band mean,
    :mod:`bayesnsi.nsi._line_information`); the quality index and the spread stay those of the plain
    mean, so that the guards read the same index either way.

    Parameters
    ----------
    spectrum : ndarray, shape (n_freq, n_terms)
        λ_i(ω) on a grid over ``band`` (:func:`coefficient_spectrum`).
    terms : sequence of Term
    band : (float, float)
        The averaging band [Hz].
    weights : ndarray, shape (n_freq, n_terms), optional
        Non-negative weight of each line (default: equal). A term whose kept lines weigh nothing
        gets the plain mean.

    Returns
    -------
    tuple of CoefficientEstimate
        Mean real part, mean |Im|/|Re| (the quality index), the spread of the real part and the
        fraction of lines left out.
    """
    out = []
    for k, term in enumerate(terms):
        keep = consistent_lines(spectrum[:, k].real)
        lines = spectrum[keep, k]
        plain = float(np.mean(lines.real))
        value = plain
        if weights is not None:
            w = np.asarray(weights, dtype=float)[keep, k]
            if np.all(np.isfinite(w)) and np.sum(w) > 0:
                value = float(np.sum(w * lines.real) / np.sum(w))
        out.append(CoefficientEstimate(
            term=term,
            value=value,
            imag_ratio=float(np.mean(np.abs(lines.imag)) / abs(plain)),
            band_hz=band,
            spread=float(np.std(lines.real)),
            excluded_fraction=float(1.0 - np.mean(keep)),
        ))
    return tuple(out)


EXCLUDED_NOTE_FRACTION = 0.02
"""Fraction of a band's lines left out from which :func:`excluded_lines_findings` says so (the simulated
GVT's joint at 1 N left out 0.2-1 % of its lines; results.json carries every ``excluded_fraction``)."""


def excluded_lines_findings(outcomes, selected: str | None) -> tuple[Finding, ...]:
    """For the selected candidate, a finding per coefficient whose band mean left out at least
    :data:`EXCLUDED_NOTE_FRACTION` of its lines (:func:`band_coefficients`).

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
        With ``name`` and ``result`` (an NSIResult or None).
    selected : str or None
        The selected candidate.

    Returns
    -------
    tuple of Finding
        Kind ``"band.excluded_lines"``; empty when the selected model's λ_i(ω) are consistent over
        the whole band.
    """
    out = []
    for outcome in outcomes:
        result = outcome.result
        if outcome.name != selected or result is None:
            continue
        for c in result.coefficients:
            if c.excluded_fraction >= EXCLUDED_NOTE_FRACTION:
                message = (
                    f"the selected model {selected!r}: λ(ω) of {c.term.name} runs away on "
                    f"{100 * c.excluded_fraction:.1f} % of the averaging band {c.band_hz[0]:.4g}-{c.band_hz[1]:.4g} Hz "
                    f"(more than {OUTLIER_SCALES:g} robust sds from its median, typically near a zero of the transfer "
                    "function it is divided by); "
                    "those lines are left out of its value and quality index - see its λ(ω) figure, or give "
                    "[nsi] band_hz to choose the band"
                )
                values = {"term": c.term.name, "excluded_fraction": float(c.excluded_fraction),
                          "band_low_hz": float(c.band_hz[0]), "band_high_hz": float(c.band_hz[1])}
                out.append(Finding("band.excluded_lines", message, str(selected), "warning", values))
    return tuple(out)
