"""Periodic data: period-averaged spectra, noise per line, best linear approximation (docs/method.md §11).

A periodic test repeats the same force for several periods of ``P`` samples. The DFT of each
period gives the force and the responses on the same lines ``k`` (frequency ``k fs / P``); their
means over the periods carry the signal and their spread the noise, per line and channel
(the variance of the mean is the spread over periods divided by their number). Only the lines the
force excites carry information about the linear dynamics.

With several realisations (new random phases) of ``P`` periods each, the best linear
approximation (Pintelon and Schoukens, *System Identification*, 2nd ed., ch. 3-4) is the mean of
the realisations' FRFs; the spread over the periods measures the noise, the spread over the
realisations the noise plus the stochastic nonlinear distortion, and their difference the
distortion. Output power at the lines a random-odd multisine leaves out shows odd (unexcited odd
lines) and even (even lines) nonlinearities before any model is built.

DFT convention: ``X(k) = (1/P) Σ_t x_t e^{-2πjkt/P}`` (numpy ``rfft`` divided by P), lines
``k = 0 .. P//2``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError
from ..signals import Signals

__all__ = [
    "BestLinearApproximation",
    "PeriodicSpectra",
    "best_linear_approximation",
    "excited_lines",
    "period_dft",
    "period_spectra",
    "periodic_integration",
]

EXCITED_DB = 40.0
"""A line is excited when its force power is within this many dB of the strongest line."""


def period_dft(signal, period: int, drop: int = 0) -> np.ndarray:
    """DFT of each whole period of a record.

    Parameters
    ----------
    signal : array_like, shape (n_samples,) or (n_samples, n_channels)
        Time signal; samples after the last whole period are ignored.
    period : int
        Samples per period P.
    drop : int
        Leading periods left out (transient).

    Returns
    -------
    ndarray of complex, shape (n_periods, P // 2 + 1, n_channels)
        ``rfft`` of each period divided by P.

    Raises
    ------
    InputDataError
        When ``period`` or ``drop`` is not a usable integer, or fewer than one period remains.
    """
    x = np.asarray(signal, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    period, drop = _check_period(period, drop)
    n_periods = x.shape[0] // period - drop
    if n_periods < 1:
        raise InputDataError(
            f"the record of {x.shape[0]} samples holds {x.shape[0] // period} whole period(s) of {period} "
            f"samples; dropping {drop} leaves none"
        )
    blocks = x[drop * period : (drop + n_periods) * period].reshape(n_periods, period, x.shape[1])
    return np.fft.rfft(blocks, axis=1) / period


def excited_lines(force_power, noise_power=None, threshold_db: float = EXCITED_DB) -> np.ndarray:
    """Lines a force excites: within ``threshold_db`` of the strongest line and above its noise.

    Parameters
    ----------
    force_power : array_like, shape (n_lines,)
        Power of the period-averaged force at each line (summed over force channels).
    noise_power : array_like, shape (n_lines,), optional
        Noise variance of that average; an excited line must exceed 10 times it.
    threshold_db : float
        Dynamic range accepted below the strongest line.

    Returns
    -------
    ndarray of bool, shape (n_lines,)
        The DC line is never excited.
    """
    power = np.asarray(force_power, dtype=float)
    level = float(np.max(power[1:])) if len(power) > 1 else 0.0
    mask = power > level * 10.0 ** (-threshold_db / 10.0)
    if noise_power is not None:
        mask &= power > 10.0 * np.asarray(noise_power, dtype=float)
    mask[0] = False
    return mask


@dataclass(frozen=True)
class PeriodicSpectra:
    """Period-averaged spectra of forces and responses with their noise per line.

    Attributes
    ----------
    fs : float
        Sampling frequency [Hz].
    period : int
        Samples per period P.
    n_periods : int
        Periods averaged (after the dropped ones).
    freqs_hz : ndarray, shape (P // 2 + 1,)
        Frequency of each line [Hz].
    force : ndarray of complex, shape (n_lines, m)
        Mean force spectrum over the periods.
    response : ndarray of complex, shape (n_lines, l)
        Mean response (displacement) spectrum.
    force_var : ndarray, shape (n_lines, m)
        Noise variance of the mean force (spread over periods / n_periods; NaN for one period).
    response_cov : ndarray of complex, shape (n_lines, l, l)
        Noise covariance of the mean response, per line (Hermitian).
    excited : ndarray of bool, shape (n_lines,)
        Lines the force excites (:func:`excited_lines`).
    """

    fs: float
    period: int
    n_periods: int
    freqs_hz: np.ndarray
    force: np.ndarray
    response: np.ndarray
    force_var: np.ndarray
    response_cov: np.ndarray
    excited: np.ndarray

    @property
    def response_var(self) -> np.ndarray:
        """Noise variance of the mean response per line and channel, shape (n_lines, l)."""
        return np.real(np.diagonal(self.response_cov, axis1=1, axis2=2))

    def lines(self, band_hz=None) -> np.ndarray:
        """Indices of the excited lines, optionally only those inside ``band_hz``.

        Parameters
        ----------
        band_hz : (float, float), optional
            Band [Hz], ends included.

        Returns
        -------
        ndarray of int
        """
        mask = self.excited.copy()
        if band_hz is not None:
            mask &= (self.freqs_hz >= band_hz[0]) & (self.freqs_hz <= band_hz[1])
        return np.flatnonzero(mask)


def period_spectra(signals: Signals, period: int | None = None, drop: int = 0) -> PeriodicSpectra:
    """Period-averaged force and displacement spectra, their noise per line, the excited lines.

    Parameters
    ----------
    signals : Signals
        A periodic record (forces repeated every ``period`` samples).
    period : int, optional
        Samples per period; default ``signals.period``.
    drop : int
        Leading (transient) periods left out.

    Returns
    -------
    PeriodicSpectra

    Raises
    ------
    InputDataError
        Without a period, or when no whole period remains.
    """
    period = _period_of(signals, period)
    forces = period_dft(signals.force, period, drop)
    responses = period_dft(signals.displacement, period, drop)
    n_periods = forces.shape[0]
    force = forces.mean(axis=0)
    response = responses.mean(axis=0)
    if n_periods > 1:
        force_var = np.sum(np.abs(forces - force) ** 2, axis=0) / (n_periods - 1) / n_periods
        dev = responses - response
        response_cov = np.einsum("pki,pkj->kij", dev, dev.conj()) / (n_periods - 1) / n_periods
    else:
        force_var = np.full(force.shape, np.nan)
        response_cov = np.full(response.shape + (response.shape[1],), np.nan, dtype=complex)
    noise = None if n_periods == 1 else force_var.sum(axis=1)
    excited = excited_lines(np.sum(np.abs(force) ** 2, axis=1), noise)
    return PeriodicSpectra(
        fs=signals.fs,
        period=period,
        n_periods=n_periods,
        freqs_hz=np.fft.rfftfreq(period, 1.0 / signals.fs),
        force=force,
        response=response,
        force_var=force_var,
        response_cov=response_cov,
        excited=excited,
    )


@dataclass(frozen=True)
class BestLinearApproximation:
    """Best linear approximation of one force to the responses, with noise and distortion levels.

    Variances are those of ``frf`` (FRF units squared); ``sqrt`` of them is what an FRF plot
    shows beside ``|frf|``. Output powers are in displacement units squared.

    Attributes
    ----------
    freqs_hz : ndarray, shape (n_exc,)
        Excited lines (excited in every realisation) [Hz].
    frf : ndarray of complex, shape (n_exc, l)
        G_BLA: mean over realisations of the period-averaged FRFs.
    noise_var : ndarray, shape (n_exc, l)
        Variance of ``frf`` due to noise (from the spread over periods).
    total_var : ndarray, shape (n_exc, l)
        Variance of ``frf`` from the spread over realisations: noise plus stochastic
        nonlinear distortion (NaN with one realisation).
    distortion_var : ndarray, shape (n_exc, l)
        ``max(total_var - noise_var, 0)``.
    odd_hz, even_hz : ndarray
        Odd and even lines excited in no realisation, between the lowest and highest line
        excited in all [Hz].
    odd_power, even_power : ndarray, shape (n_odd, l) and (n_even, l)
        Mean over realisations of the output power |Y|² at those lines.
    odd_noise, even_noise : ndarray, same shapes
        Noise variance of the period-averaged output there (the level ``*_power`` would have
        without nonlinear distortion).
    n_realisations, n_periods : int
    force_level : float
        RMS over realisations and excited lines of the force spectrum |U|; ``sqrt(odd_power) /
        force_level`` puts the unexcited lines' output in FRF units (the distortion level of one
        realisation, beside ``sqrt(noise_var)``).
    """

    freqs_hz: np.ndarray
    frf: np.ndarray
    noise_var: np.ndarray
    total_var: np.ndarray
    distortion_var: np.ndarray
    odd_hz: np.ndarray
    even_hz: np.ndarray
    odd_power: np.ndarray
    even_power: np.ndarray
    odd_noise: np.ndarray
    even_noise: np.ndarray
    n_realisations: int
    n_periods: int
    force_level: float = float("nan")

    def distortion_ratio(self) -> np.ndarray:
        """Median over the excited lines of total / noise variance, per channel (≈ 1: linear).

        Returns
        -------
        ndarray, shape (l,)
        """
        return np.median(self.total_var / self.noise_var, axis=0)

    def unexcited_ratio(self) -> dict[str, np.ndarray]:
        """Median output power over noise level at the unexcited odd and even lines, per channel.

        Returns
        -------
        dict
            ``{"odd": (l,), "even": (l,)}``; NaN where there is no such line.
        """
        out = {}
        for name, power, noise in (("odd", self.odd_power, self.odd_noise), ("even", self.even_power, self.even_noise)):
            out[name] = np.median(power / noise, axis=0) if len(power) else np.full(self.frf.shape[1], np.nan)
        return out


def best_linear_approximation(
    realisations: Sequence[Signals], period: int | None = None, drop: int = 0
) -> BestLinearApproximation:
    """Best linear approximation and the split of its variance into noise and distortion.

    Parameters
    ----------
    realisations : sequence of Signals
        M records of one force channel (the same excited lines, new phases), each of P
        periods of ``period`` samples, the same sampling and channels; a record of several
        ``realisations`` (:func:`bayesnsi.signals.join_realisations`) counts as each of them.
    period : int, optional
        Samples per period; default each record's ``period``.
    drop : int
        Leading (transient) periods left out of each record.

    Returns
    -------
    BestLinearApproximation

    Raises
    ------
    InputDataError
        With more than one force channel, fewer than two periods, records that differ in
        period or channels, or no line excited in every realisation.
    """
    if isinstance(realisations, Signals):
        realisations = [realisations]
    realisations = [one for s in realisations for one in s.realisation_records()]  # a joined record: each of its own
    if not realisations:
        raise InputDataError("best_linear_approximation needs at least one record")
    spectra = [period_spectra(s, period, drop) for s in realisations]
    first = spectra[0]
    if first.force.shape[1] != 1:
        raise InputDataError(
            f"the best linear approximation here takes one force channel, got {first.force.shape[1]}; "
            "use one shaker per record"
        )
    if any(s.period != first.period or s.response.shape != first.response.shape for s in spectra):
        raise InputDataError("every realisation needs the same period and the same channels")
    if first.n_periods < 2:
        raise InputDataError("the noise level needs at least two periods per realisation (after the dropped ones)")
    excited = np.logical_and.reduce([s.excited for s in spectra])
    lines = np.flatnonzero(excited)
    if not len(lines):
        raise InputDataError("no line is excited in every realisation; use the same multisine lines in each")
    frfs, noise = [], []
    for s in spectra:
        u = s.force[lines, 0]
        g = s.response[lines] / u[:, None]
        # first-order noise of Y/U: (σ²_Y + |G|² σ²_U) / |U|² (input and output noise independent)
        var = (s.response_var[lines] + np.abs(g) ** 2 * s.force_var[lines, :1]) / np.abs(u[:, None]) ** 2
        frfs.append(g)
        noise.append(var)
    g_all = np.array(frfs)
    n_real = len(spectra)
    frf = g_all.mean(axis=0)
    noise_var = np.sum(noise, axis=0) / n_real**2
    if n_real > 1:
        total_var = np.sum(np.abs(g_all - frf) ** 2, axis=0) / (n_real * (n_real - 1))
    else:
        total_var = np.full(frf.shape, np.nan)
    unexcited = np.zeros_like(excited)
    unexcited[lines[0] : lines[-1] + 1] = True
    unexcited &= ~np.logical_or.reduce([s.excited for s in spectra])
    k = np.arange(len(excited))
    odd, even = np.flatnonzero(unexcited & (k % 2 == 1)), np.flatnonzero(unexcited & (k % 2 == 0))
    power = np.mean([np.abs(s.response) ** 2 for s in spectra], axis=0)
    level = np.mean([s.response_var for s in spectra], axis=0)
    return BestLinearApproximation(
        freqs_hz=first.freqs_hz[lines],
        frf=frf,
        noise_var=noise_var,
        total_var=total_var,
        distortion_var=np.maximum(total_var - noise_var, 0.0),
        odd_hz=first.freqs_hz[odd],
        even_hz=first.freqs_hz[even],
        odd_power=power[odd],
        even_power=power[even],
        odd_noise=level[odd],
        even_noise=level[even],
        n_realisations=n_real,
        n_periods=first.n_periods,
        force_level=float(np.sqrt(np.mean([np.abs(s.force[lines, 0]) ** 2 for s in spectra]))),
    )


def periodic_integration(acceleration, fs: float, period: int, band_hz,
                         measured: str = "acceleration") -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement of a periodic record from its acceleration, line by line.

    Over whole periods the DFT lines of a steady-state response are exact, so ``V = A/(jω)`` and
    ``X = A/(jω)²`` on every line inside ``band_hz`` hold without a filter transient, a window or
    drift; the lines outside the band (the DC line always) are set to zero: below the band the
    division amplifies noise and drift, and the frequency route fits nothing there. A measured
    velocity (``measured="velocity"``) is integrated once: ``X = V/(jω)``, V kept in the band.

    Parameters
    ----------
    acceleration : array_like, shape (n_samples,) or (n_samples, n_channels)
        Whole periods of a periodic acceleration [m/s²] (or velocity [m/s]).
    fs : float
        Sampling frequency [Hz].
    period : int
        Samples per period.
    band_hz : (float, float)
        Lines kept [Hz], ends included.
    measured : {"acceleration", "velocity"}
        What ``acceleration`` holds: integrated twice or once.

    Returns
    -------
    velocity, displacement : ndarray, shape (n_samples, n_channels)
        [m/s] and [m] (for accelerations in m/s²).

    Raises
    ------
    InputDataError
        When the record does not hold whole periods or the band holds no line.
    """
    a = np.asarray(acceleration, dtype=float)
    squeeze = a.ndim == 1
    a = a.reshape(len(a), -1)
    period = _check_period(period, 0)[0]
    if len(a) % period or not len(a):
        raise InputDataError(
            f"periodic integration needs whole periods: {len(a)} samples are not a multiple of the period {period}; "
            "give the estimation and validation windows in whole periods"
        )
    spectrum = np.fft.rfft(a, axis=0)
    freqs = np.fft.rfftfreq(len(a), 1.0 / fs)
    keep = (freqs >= band_hz[0]) & (freqs <= band_hz[1]) & (freqs > 0) & (freqs < fs / 2)
    if not keep.any():
        raise InputDataError(f"band {tuple(band_hz)} Hz holds no DFT line of the record; widen the band")
    from ..preprocess import INTEGRATED_QUANTITIES

    if measured not in INTEGRATED_QUANTITIES:
        raise InputDataError(f"measured must be one of {INTEGRATED_QUANTITIES}, got {measured!r}")
    times = 2 if measured == "acceleration" else 1
    jw = np.where(keep, 2j * np.pi * freqs, 1.0)[:, None]
    velocity = np.fft.irfft(np.where(keep[:, None], spectrum / jw ** (times - 1), 0.0), len(a), axis=0)
    displacement = np.fft.irfft(np.where(keep[:, None], spectrum / jw**times, 0.0), len(a), axis=0)
    return (velocity[:, 0], displacement[:, 0]) if squeeze else (velocity, displacement)


def _period_of(signals: Signals, period) -> int:
    if not isinstance(signals, Signals):
        raise InputDataError(f"periodic spectra need a Signals object, got {type(signals).__name__}")
    period = getattr(signals, "period", None) if period is None else period
    if period is None:
        raise InputDataError("the record has no period; give period = samples per period ([data] period)")
    return int(_check_period(period, 0)[0])


def _check_period(period, drop) -> tuple[int, int]:
    if isinstance(period, bool) or not isinstance(period, (int, np.integer)) or period < 2:
        raise InputDataError(f"period must be an integer number of samples >= 2, got {period!r}")
    if isinstance(drop, bool) or not isinstance(drop, (int, np.integer)) or drop < 0:
        raise InputDataError(f"drop (leading transient periods) must be an integer >= 0, got {drop!r}")
    return int(period), int(drop)
