"""Motion the force drives below the integration band (accelerometers on a free body).

``[data] integrate`` high-passes the accelerations at ``f_lo``: whatever the structure does below
it is lost, true motion as well as drift. For a structure held by springs that is the little
static deflection below its first mode; for a **free body** (no spring to ground: a carriage on
rails, a free-free test article) it is the rigid-body motion, most of the displacement and the
velocity whose sign drives the friction. Integrated accelerations of a free body then hold a
band-passed motion, the identified model an artefact mode near ``f_lo`` instead of the rigid-body
poles, and every term of a velocity or displacement (``sign(v)``, ``v|v|``, ``x³``) is evaluated
on motion that did not happen. Measured on a free-free two-mass rig (force with a 0.5 Hz
travel and 1-40 Hz random content, ``band_hz = [2, 100]``): a mode at 0.41 Hz with ζ = 0.54,
Coulomb friction 0.063 N for 1.5 N.

Before integration the loader estimates, from the force and the accelerations, how much of the
displacement the force drives lies below the band: the coherent part of each acceleration's
spectrum (multiple-input H1) divided by ω⁴. When more than :data:`BELOW_BAND_LIMIT` of it lies
below ``f_lo`` the record is loaded with a :class:`~bayesnsi.exceptions.IntegrationWarning`
naming the channel, the share, and whether the accelerance there is a mass line (real and
positive, flat: a rigid-body motion).
"""

from __future__ import annotations

import numpy as np

__all__ = ["BELOW_BAND_LIMIT", "EDGE_SNR_MIN", "below_band_messages", "noise_edge_messages"]

BELOW_BAND_LIMIT = 0.5
"""Share of the force-driven displacement below ``f_lo`` above which the loader warns."""

EDGE_SNR_MIN = 10.0
"""Median ratio of a channel's measured power to its white noise's over ``[f_lo, 1.5 f_lo]`` below
which the loader warns (:func:`noise_edge_messages`)."""


def _spectra(force: np.ndarray, acc: np.ndarray, fs: float, f_lo: float):
    """Welch auto/cross spectra with lines fine enough to resolve ``f_lo / 8``."""
    from scipy.signal import csd  # here: the loader is on every command's path, scipy.signal costs 0.2 s

    n = len(force)
    nperseg = int(min(n, 2 ** np.ceil(np.log2(max(16.0, 8.0 * fs / f_lo)))))
    m, l = force.shape[1], acc.shape[1]
    freqs, _ = csd(force[:, 0], force[:, 0], fs=fs, nperseg=nperseg)
    sff = np.empty((len(freqs), m, m), dtype=complex)
    sfa = np.empty((len(freqs), m, l), dtype=complex)
    for i in range(m):
        for j in range(m):
            sff[:, i, j] = csd(force[:, i], force[:, j], fs=fs, nperseg=nperseg)[1]
        for o in range(l):
            sfa[:, i, o] = csd(force[:, i], acc[:, o], fs=fs, nperseg=nperseg)[1]
    return freqs, sff, sfa


def below_band_messages(force, acc, fs: float, band_hz, names, measured: str = "acceleration") -> list[str]:
    """Messages for the acceleration (or velocity) channels whose force-driven motion lies mostly below ``f_lo``.

    Parameters
    ----------
    force : array_like, shape (n_samples, m)
        Measured forces (before any band filter).
    acc : array_like, shape (n_samples, l)
        Measured accelerations (velocities for ``measured = "velocity"``) before integration.
    fs : float
        Sampling frequency [Hz].
    band_hz : (float, float)
        The integration band ``(f_lo, f_hi)``.
    names : sequence of str
        Column names of the accelerations (for the messages).
    measured : {"acceleration", "velocity"}
        What ``acc`` holds: its displacement is its power over (2πf)⁴ or (2πf)².

    Returns
    -------
    list of str
        One message per channel above :data:`BELOW_BAND_LIMIT`; empty when none is.
    """
    force = np.asarray(force, dtype=float).reshape(len(force), -1)
    acc = np.asarray(acc, dtype=float).reshape(len(acc), -1)
    f_lo = float(band_hz[0])
    if len(force) < 64 or f_lo <= 0:
        return []
    freqs, sff, sfa = _spectra(force, acc, fs, f_lo)
    lines = freqs >= 2 * freqs[1]  # the first lines hold the window's leakage of the means
    top = min(float(band_hz[1]), fs / 2)
    lines &= freqs <= top
    sff, sfa, freqs = sff[lines], sfa[lines], freqs[lines]
    # coherent acceleration power per channel: sfa^H sff^-1 sfa (multiple-input H1)
    try:
        h = np.linalg.solve(sff + 1e-12 * np.trace(sff, axis1=1, axis2=2)[:, None, None].real * np.eye(sff.shape[1]),
                            sfa)
    except np.linalg.LinAlgError:
        return []
    coherent = np.real(np.einsum("kio,kio->ko", np.conj(h), sfa))
    displacement = coherent / (2 * np.pi * freqs[:, None]) ** (4 if measured == "acceleration" else 2)
    below = freqs < f_lo
    total = displacement.sum(axis=0)
    if not below.any():
        return []
    out = []
    for o, name in enumerate(names):
        if total[o] <= 0:
            continue
        share = float(displacement[below, o].sum() / total[o])
        if share <= BELOW_BAND_LIMIT:
            continue
        k = int(np.argmax(displacement[below, o]))
        accelerance = h[below][k, :, o]
        mass_line = measured == "acceleration" and bool(
            np.all(accelerance.real > 0) and np.all(np.abs(accelerance.imag) < accelerance.real))
        what = (" (the accelerance there is real and positive, a mass line: rigid-body motion of a free body)"
                if mass_line else "")
        out.append(
            f"{measured} {name!r}: {100 * share:.0f} % of the displacement the force drives lies below the "
            f"integration band's lower edge f_lo = {f_lo:g} Hz, most at {freqs[below][k]:.3g} Hz{what}; integration "
            "removes it, so the model and every term of a displacement or velocity (sign(v), v|v|, x³) see a "
            "band-passed motion that did not happen. Measure displacement"
            f"{' or velocity' if measured == 'acceleration' else ''} at that DOF (a free body cannot be identified "
            f"from {'accelerations' if measured == 'acceleration' else 'velocities'} alone), or lower f_lo if the "
            "motion is a structure's"
        )
    return out


def noise_edge_messages(acc, noise_std, fs: float, band_hz, names, measured: str = "acceleration") -> list[str]:
    """Messages for the channels whose motion at the integration band's lower edge is buried in their noise.

    Integrated, a sensor's white noise grows as 1/ω⁴ (accelerometers) or 1/ω² (velocity sensors)
    towards ``f_lo``; where the measured power there is not well above the noise's, the integrated
    displacement near ``f_lo`` is mostly integrated noise, which the subspace step fits as a heavily
    damped "mode" near ``f_lo`` in place of a structural one (a three-DOF chain integrated from 2 Hz
    with 2 % accelerometer noise: a 2.09 Hz "mode" replaced the 42 Hz one and a cubic coefficient
    read 26 % low; integrated from 4.6 Hz, where the motion clears the noise, the three modes within
    0.2 % in frequency and the coefficient within 5 %). A channel warns when the median over
    ``[f_lo, 1.5 f_lo]`` of its motion's power over the noise's (measured power over the noise's,
    less one) is below :data:`EDGE_SNR_MIN`; the message names the lowest frequency from which that
    median is above it.

    Parameters
    ----------
    acc : array_like, shape (n_samples, l)
        Measured accelerations (velocities for ``measured = "velocity"``) before integration.
    noise_std : array_like, shape (l,)
        White noise std of each channel (estimated or declared).
    fs : float
        Sampling frequency [Hz].
    band_hz : (float, float)
        The integration band ``(f_lo, f_hi)``.
    names : sequence of str
        Column names of the channels (for the messages).
    measured : {"acceleration", "velocity"}
        What ``acc`` holds.

    Returns
    -------
    list of str
        One message naming the channels below the limit; empty when none is.
    """
    from scipy.signal import welch  # here: the loader is on every command's path

    acc = np.asarray(acc, dtype=float).reshape(len(acc), -1)
    noise_power = 2.0 * np.asarray(noise_std, dtype=float) ** 2 / float(fs)  # one-sided white density
    f_lo, top = float(band_hz[0]), min(float(band_hz[1]), fs / 2)
    if len(acc) < 64 or f_lo <= 0 or 1.5 * f_lo >= top or not np.all(noise_power > 0):
        return []
    nperseg = int(min(len(acc), 2 ** np.ceil(np.log2(max(16.0, 8.0 * fs / f_lo)))))
    freqs, power = welch(acc, fs=fs, nperseg=nperseg, axis=0)
    snr = power / noise_power[None, :] - 1.0

    def edge_median(f0: float) -> np.ndarray:
        lines = (freqs >= f0) & (freqs <= 1.5 * f0)
        return np.median(snr[lines], axis=0) if lines.any() else np.full(acc.shape[1], np.inf)

    at_edge = edge_median(f_lo)
    starts = freqs[(freqs > f_lo) & (freqs <= top / 1.5)]
    low = [o for o in range(acc.shape[1]) if at_edge[o] < EDGE_SNR_MIN]
    if not low:
        return []
    clear = [next((float(f0) for f0 in starts if edge_median(f0)[o] >= EDGE_SNR_MIN), np.nan) for o in low]
    if np.all(np.isfinite(clear)):
        advice = (f"the motion clears {EDGE_SNR_MIN:g}x the noise from about {max(clear):.3g} Hz (channel by channel: "
                  f"{', '.join(f'{c:.3g}' for c in clear)} Hz): raise [data] integrate band_hz[0] to about "
                  f"{max(clear):.3g} Hz")
    else:
        advice = (f"on {int(np.sum(~np.isfinite(clear)))} channel(s) it stays below {EDGE_SNR_MIN:g}x up to "
                  f"{top / 1.5:.3g} Hz: check the sensors and their noise_std")
    channels = ", ".join(repr(names[o]) for o in low)
    ratios = ", ".join(f"{max(float(at_edge[o]), 0.0):.2g}x" for o in low)
    return [
        f"{measured} {channels}: over {f_lo:g}-{1.5 * f_lo:g} Hz, at the integration band's lower edge, the motion's "
        f"power is only {ratios} that of the sensor's white noise; integrated, that noise grows as "
        f"1/ω{'⁴' if measured == 'acceleration' else '²'} towards {f_lo:g} Hz and weighs heavily in the displacement "
        f"there, and the subspace step can fit it as a heavily damped mode near {f_lo:g} Hz in place of a structural "
        f"one; {advice}"
    ]
