"""Where the data inform λ_i(ω): the line weights of the information-weighted band mean (docs/method.md §4).

Each line ω of the averaging band estimates λ_i(ω) from the part of the outputs that the term's
input ``-n_i`` drives through the extended FRF column ``H_E[:, m+i](ω)``. To first order the
relative variance of that estimate is the output noise over the power of that part, so the line's
weight is its signal-to-noise ratio

    w_i(ω) = Σ_o |H_E[o, m+i](ω)|² S_{n_i}(ω) / S_{e,o}(ω),

with ``S_{n_i}`` the power spectral density of the term's input (averaged periodogram of the
record) and ``S_{e,o}`` that of the noise on output o: white at the level the data show for
displacement sensors, and the sensor's white noise integrated once (velocity sensors, ``/ω²``) or
twice (accelerometers, ``/ω⁴``) for records integrated in time. Near the integration corner the
integrated noise dominates, and a plain band mean averages lines that carry no information
(a three-DOF chain measured by accelerometers: λ(ω) 20 % low at 7 Hz with a 4 % scatter, 0.1 % at
33 Hz; docs/measurements.md, "Information-weighted band mean").
"""

from __future__ import annotations

import numpy as np

__all__ = ["averaged_periodogram", "band_weighting", "line_information", "output_noise_psd"]

_SEGMENT = 4096  # samples per periodogram segment (at most an eighth of the record)


def averaged_periodogram(columns: np.ndarray, fs: float, freqs_hz) -> np.ndarray:
    """Power spectral density of each column at ``freqs_hz``: Hann-windowed segments, averaged (Welch).

    Parameters
    ----------
    columns : ndarray, shape (n_samples, n_columns)
        The record.
    fs : float
        Its sampling frequency [Hz].
    freqs_hz : array_like, shape (n_freq,)
        Where the density is wanted; interpolated linearly between the periodogram's bins.

    Returns
    -------
    ndarray, shape (n_freq, n_columns)
        One-sided density [unit² / Hz].
    """
    x = np.asarray(columns, dtype=float).reshape(len(columns), -1)
    n = len(x)
    length = int(min(_SEGMENT, 2 ** max(int(np.log2(max(n // 8, 8))), 3)))
    starts = range(0, n - length + 1, length // 2)  # half overlap
    window = np.hanning(length)
    power = np.zeros((length // 2 + 1, x.shape[1]))
    for start in starts:
        segment = x[start : start + length]
        spectrum = np.fft.rfft((segment - segment.mean(axis=0)) * window[:, None], axis=0)
        power += np.abs(spectrum) ** 2
    power *= 2.0 / (fs * np.sum(window**2) * len(starts))
    bins = np.fft.rfftfreq(length, 1.0 / fs)
    freqs = np.asarray(freqs_hz, dtype=float)
    return np.column_stack([np.interp(freqs, bins, power[:, c]) for c in range(x.shape[1])])


def output_noise_psd(freqs_hz, displacement_std, sensor_noise=None) -> np.ndarray:
    """Relative power spectral density of the noise on each displacement channel.

    Parameters
    ----------
    freqs_hz : array_like, shape (n_freq,)
        Frequencies [Hz] (positive).
    displacement_std : array_like, shape (l,)
        White noise std of each displacement channel (used when ``sensor_noise`` is None).
    sensor_noise : AccelerationNoise, optional
        The white noise of the sensors a record was integrated from (accelerometers or velocity
        sensors, :class:`bayesnsi.noise.integrated.AccelerationNoise`).

    Returns
    -------
    ndarray, shape (n_freq, l)
        Proportional to the noise density (a common factor does not change the weights).
    """
    freqs = np.asarray(freqs_hz, dtype=float)[:, None]
    if sensor_noise is None:
        level = np.asarray(displacement_std, dtype=float) ** 2
        return np.broadcast_to(level[None, :], (len(freqs), len(level))).copy()
    power = 4 if sensor_noise.measured == "acceleration" else 2
    level = np.asarray(sensor_noise.acceleration_std, dtype=float) ** 2
    return level[None, :] / (2.0 * np.pi * freqs) ** power


def line_information(frf_terms: np.ndarray, term_psd: np.ndarray, noise_psd: np.ndarray) -> np.ndarray:
    """The weights ``w_i(ω) = Σ_o |H_E[o, m+i](ω)|² S_{n_i}(ω) / S_{e,o}(ω)`` (module notes).

    Parameters
    ----------
    frf_terms : ndarray, shape (n_freq, l, q)
        The extended FRF's columns of the q terms.
    term_psd : ndarray, shape (n_freq, q)
        Power spectral density of each term's input.
    noise_psd : ndarray, shape (n_freq, l)
        Noise density of each output (:func:`output_noise_psd`).

    Returns
    -------
    ndarray, shape (n_freq, q)
        Non-negative; zero where a noise density is not positive and finite.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = np.where((noise_psd > 0) & np.isfinite(noise_psd), 1.0 / noise_psd, 0.0)
    gain = np.abs(frf_terms) ** 2 * inverse[:, :, None]
    weights = np.sum(gain, axis=1) * np.asarray(term_psd, dtype=float)
    return np.where(np.isfinite(weights) & (weights > 0), weights, 0.0)


def band_weighting(band_mean: str, u: np.ndarray, displacement_std, measured):
    """The line weights of a time-route identification, as a function of its FRF (None: the plain mean).

    Parameters
    ----------
    band_mean : {"auto", "information", "plain"}
        ``NSIOptions.band_mean``: "auto" weighs records integrated from accelerometers or velocity
        sensors (their noise density spans orders of magnitude over a band) and no others.
    u : ndarray, shape (n_samples, m + q)
        The extended input the model was identified from (forces, then the terms' inputs).
    displacement_std : array_like, shape (l,)
        White noise std of each displacement channel (used unless the record was integrated).
    measured : Signals
        The record as measured (its integrated sensors' noise, if any).

    Returns
    -------
    callable or None
        ``weights(frf, freqs_hz, m, dt)`` -> ndarray (n_freq, q) of :func:`line_information`, or
        None for the plain mean (also where the band reaches 0 Hz).
    """
    from ..noise import acceleration_noise_of

    sensor_noise = acceleration_noise_of(measured)
    if band_mean == "plain" or (band_mean == "auto" and sensor_noise is None):
        return None
    noise_std = np.asarray(displacement_std, dtype=float)

    def weights(frf: np.ndarray, freqs_hz: np.ndarray, m: int, dt: float):
        if freqs_hz[0] <= 0:
            return None
        term_psd = averaged_periodogram(u[:, m:], 1.0 / dt, freqs_hz)
        return line_information(frf[:, :, m:], term_psd, output_noise_psd(freqs_hz, noise_std, sensor_noise))

    return weights
