"""The quality index judged against the model's own misfit (docs/method.md §7, "The quality index and model error").

Used by the loop's quality check (:mod:`bayesnsi.loop.quality`) and by the model checks behind ``select``'s
plausible model (:func:`bayesnsi.checks.adequacy.model_checks`): one rule.

The quality index |Im λ|/|Re λ| of an effect's coefficient (docs/method.md §4) asks whether λ(ω) is one
real number over the band, a static term and not a filter. Its limit ``LoopOptions.max_imag_ratio`` was
set on models whose residual is at the noise level. Where the linear part itself misfits the data (a
measured structure whose modes move with the level: on the F-16 the residual is 7-20 times the noise on
the fitted lines), λ(ω) carries that misfit as well, for the true and the wrong terms alike, and the index
no longer tells them apart. It is then judged against the misfit the model leaves, with two numbers read
from the model's open-loop reconstruction (the view in which NSI reads λ(ω)) and a draw of the record's
noise, per frequency line (one period of a periodic record, Welch segments otherwise):

* the **misfit ratio** κ: the residual's rms over that of the noise the model passes on
  (:func:`bayesnsi.checks.residual_bands.propagated_noise`) on the data the model was fitted to (the fitted
  lines of the frequency route, the whole record on the time route), the largest over the outputs: the
  adequacy ratio of the model checks (1: down to the noise);
* the **memory resolution** M = Σ w |Im λ(ω)| / Σ w s(ω) over the lines of the λ band, weighted by where
  the effect's contribution to the outputs carries power (its information weight ``w``, the contribution's
  power over the noise's), with s(ω) the change of λ at ω that moves the outputs by the residual the model
  leaves at ω (through the effect's own path to the outputs): how far the frequency dependence of λ(ω)
  stands above what the misfit leaves undetermined.

The index passes below ``max_imag_ratio``. Above it, it decides when the model is adequate or nearly so (κ at
most ``EvidenceOptions.max_band_ratio``, 2: the misfit below which the model checks do not warn about any
band), and otherwise only when the memory is resolved (M > 1): an M at most 1 means that the imaginary part of
λ(ω) moves the outputs by no more than the misfit already there, which the index cannot attribute to the
effect. A linear spring or damper fitted between two sensors of the F-16 to absorb the linear part's model
error (a null effect, true λ = 0) reads M = 3.7-12; the interface effects, which lower every held-out error,
0.61-1.13 (docs/measurements.md, "The quality index and model error").
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import BayesNSIError, BayesNSIWarning
from ..noise import noise_model
from ..nsi import affine_reconstruction
from ..nsi.physics import coefficient_spectrum
from .residual_bands import propagated_noise

__all__ = ["MisfitReading", "index_judgement", "misfit_reading"]

MIN_BAND_BINS = 16
"""Frequency bins the segments of a non-periodic record are made long enough to put inside the λ band."""
SEGMENTS = 8
"""Segments a non-periodic record is cut into (Hann windows) when the band allows."""


@dataclass(frozen=True)
class MisfitReading:
    """How far an enlarged model misfits its data where an effect carries power (module notes).

    Attributes
    ----------
    misfit_ratio : float
        κ: the residual's rms over the noise's on the data the model was fitted to, largest over the
        outputs (NaN when it could not be read).
    resolution : float
        M: the frequency dependence of λ(ω) over the λ change the misfit leaves undetermined (NaN when
        it could not be read).
    """

    misfit_ratio: float = math.nan
    resolution: float = math.nan


def _power(x: np.ndarray, length: int, window: bool) -> np.ndarray:
    """Mean over segments of ``length`` samples of |DFT|² per channel, shape (length // 2 + 1, channels)."""
    n = (len(x) // length) * length
    segments = np.asarray(x[:n], dtype=float).reshape(n // length, length, -1)
    if window:
        segments = segments * np.hanning(length)[None, :, None]
    return np.mean(np.abs(np.fft.rfft(segments, axis=1)) ** 2, axis=0)


def _segment(signals, band, n: int) -> tuple[int, bool]:
    """Segment length and window: one period of a periodic record, else Welch segments fine enough for the band."""
    if signals.period:
        return int(signals.period), False
    width = max(float(band[1] - band[0]), signals.fs / n)
    return int(min(n, max(n // SEGMENTS, math.ceil(MIN_BAND_BINS * signals.fs / width)))), True


def misfit_reading(result, signals, index: int = -1, seed: int = 0) -> MisfitReading:
    """κ and M of one coefficient of an identified model (module notes).

    Parameters
    ----------
    result : NSIResult
        The model enlarged by the effect.
    signals : Signals
        The estimation data it was identified from.
    index : int
        Which coefficient (default the last, the effect just added).
    seed : int
        Seed of the noise draw whose spectrum stands for the noise's (:func:`bayesnsi.noise.noise_model`).

    Returns
    -------
    MisfitReading
        NaN fields when the reconstruction or the noise could not be had.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            affine = affine_reconstruction(result, signals)
            noise = noise_model(signals).draw(np.random.default_rng(seed)).displacement
            passed_on = propagated_noise(result, signals, result.reconstruct(signals).residual, n_draws=1,
                                         seed=seed)
    except (BayesNSIError, np.linalg.LinAlgError, ValueError):
        return MisfitReading()
    if not passed_on:
        return MisfitReading()
    residual = affine.measured - affine.predict(affine.estimate)
    per_unit = affine.signatures[:, :, index]  # the response to -n per unit of the NSI estimate
    estimate = float(affine.estimate[index])
    n = min(len(residual), len(noise), len(passed_on[0]))
    length, window = _segment(signals, result.band_hz, n)
    R, G, N = (_power(x[:n], length, window) for x in (residual, per_unit, noise))
    N = np.where(N > 0, N, np.finfo(float).tiny)
    freqs = np.fft.rfftfreq(length, 1.0 / signals.fs)
    low, high = result.band_hz
    path = np.sum(G / N, axis=1)  # per unit of the estimate, whitened
    inside = np.flatnonzero((freqs >= low) & (freqs <= high) & (path > 0))
    if not len(inside) or estimate == 0.0:
        return MisfitReading()
    lam = coefficient_spectrum(result.frf(freqs[inside]), result.input_dofs, result.output_dofs,
                               result.terms)[:, index]
    fitted = result.fit.fit_band_hz if result.options.domain == "frequency" else None
    data = (freqs > 0) if fitted is None else (freqs >= fitted[0]) & (freqs <= fitted[1])
    # κ against the noise the model passes on (the adequacy ratio of the model checks); M against the sensors'
    P = _power(passed_on[0][:n], length, window)
    passed = np.maximum(np.sum(P[data], axis=0), np.finfo(float).tiny)
    kappa = math.sqrt(float(np.max(np.sum(R[data], axis=0) / passed)))
    weight = estimate**2 * path[inside]  # the effect's contribution over the noise: its information weight
    rho = np.sum(R[inside] / N[inside], axis=1)  # residual over noise, summed over the outputs
    scatter = np.sqrt(rho / path[inside]) * np.abs(lam) / abs(estimate)  # λ change that moves the outputs by it
    ok = np.isfinite(lam) & np.isfinite(scatter)
    if not ok.any():
        return MisfitReading(kappa)
    resolution = float(np.sum(weight[ok] * np.abs(lam[ok].imag)) / np.sum(weight[ok] * scatter[ok]))
    return MisfitReading(kappa, resolution)


def index_judgement(imag_ratio: float, max_imag_ratio: float, misfit_bound: float,
                    reading: MisfitReading | None) -> tuple[bool, bool]:
    """Does a quality index pass, judged against its model's misfit (module notes)?

    Parameters
    ----------
    imag_ratio : float
        The coefficient's quality index |Im λ|/|Re λ|.
    max_imag_ratio : float
        Its limit on a model at the noise level (``LoopOptions.max_imag_ratio``, ``EvidenceOptions.max_imag_ratio``).
    misfit_bound : float
        ``EvidenceOptions.max_band_ratio``: up to this misfit ratio the model is (nearly) adequate and the index
        decides alone.
    reading : MisfitReading or None
        :func:`misfit_reading` of the model; None (or NaN fields) judges the index alone.

    Returns
    -------
    (bool, bool)
        Whether it passes, and whether only because its memory is not resolved against the misfit.
    """
    if float(imag_ratio) < max_imag_ratio:
        return True, False
    if reading is None or not (np.isfinite(reading.misfit_ratio) and np.isfinite(reading.resolution)):
        return False, False
    if reading.misfit_ratio <= misfit_bound or reading.resolution > 1.0:
        return False, False
    return True, True
