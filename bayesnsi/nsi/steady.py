"""Do the periods of a periodic record repeat? The force each period, the response in steady state.

The frequency route averages the periods and takes their spread as the noise. A window that holds
a period which is not like the others - the leading transient of a realisation, a period of the
next realisation (new phases) when several are concatenated in one file, or a ``period`` that is
not the force's - is not refused by anything downstream: the odd period inflates the "noise",
the weighted misfit then looks small and every result is silently worse (a window running one period into
the next realisation of a measured test gave a line misfit of 1.8 where the aligned window
gives 80, with no message). These checks say so.
"""

from __future__ import annotations

import numpy as np

from ..noise.periodic import period_deviations

__all__ = [
    "FORCE_SCATTER_LIMIT", "PERIOD_OUTLIER_LIMIT", "REPEAT_CORRELATION", "force_repeats", "period_problems",
    "repeating_period",
]

FORCE_SCATTER_LIMIT = 0.1
"""Largest period-to-period scatter of the force over the power of its period mean."""
PERIOD_OUTLIER_LIMIT = 3.0
"""Largest deviation power of one period from the period mean over the median period's.

One period of n unlike the others deviates (n - 1)² times as much as each of the rest (4 at
n = 3, 25 at n = 6); noise alone keeps the ratio near 1 (thousands of samples per period)."""


REPEAT_CORRELATION = 0.9
"""Smallest correlation of the force with itself one period later that counts as repeating (a multisine
with 30 % force noise: 0.92)."""


def repeating_period(force) -> int | None:
    """The period (samples) a force repeats with, when it repeats at least twice; else None.

    For a record loaded without ``[data] period``: a multisine test read as a plain record goes
    to the time route, which does not use the repetition (a simulated GVT file: every nonlinear
    candidate came out unstable there, with no hint that the data were periodic).

    Parameters
    ----------
    force : array_like, shape (n_samples,) or (n_samples, m)
        Forces (the first channel is used).

    Returns
    -------
    int or None
        The smallest lag, past the first fall of the autocorrelation below 1/2, at which the force
        correlates with itself (over the overlap) by at least ``REPEAT_CORRELATION``, moved up to
        the top of that correlation peak; None when there is none up to half the record.
    """
    f = np.asarray(force, dtype=float)
    f = f.reshape(len(f), -1)[:, 0]
    n = len(f)
    if n < 8 or not np.all(np.isfinite(f)):
        return None
    f = f - f.mean()
    r = np.fft.irfft(np.abs(np.fft.rfft(f, 2 * n)) ** 2, 2 * n)[:n]
    energy = np.cumsum(f**2)
    head = energy[-1] - np.concatenate([[0.0], energy[:-1]])  # Σ f[k:]²
    tail = energy[::-1]  # Σ f[:n-k]²
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(head * tail > 0, r / np.sqrt(head * tail), 0.0)
    half = n // 2
    below = np.flatnonzero(rho[1 : half + 1] < 0.5)
    if not len(below):
        return None
    start = int(below[0]) + 1
    hits = np.flatnonzero(rho[start : half + 1] >= REPEAT_CORRELATION)
    if not len(hits):
        return None
    lag = start + int(hits[0])
    while lag < half and rho[lag + 1] > rho[lag]:  # up to the peak (the first hit may be on its flank)
        lag += 1
    return lag


def force_repeats(force, period) -> bool:
    """True when the force repeats every ``period`` samples (scatter between periods within ``FORCE_SCATTER_LIMIT``).

    Parameters
    ----------
    force : array_like, shape (n_samples,) or (n_samples, m)
    period : int
        Samples per period.

    Returns
    -------
    bool
        False for fewer than two whole periods or a scatter above the limit (e.g. a sine sweep read with
        the period of a multisine test).
    """
    f = np.asarray(force, dtype=float)
    f = f.reshape(len(f), -1)
    n = len(f) // int(period)
    if n < 2:
        return False
    fp = f[: n * int(period)].reshape(n, int(period), -1)
    mean = fp.mean(axis=0)
    power = float(np.sum((mean - mean.mean(axis=0)) ** 2))
    return power > 0 and float(np.sum((fp - mean) ** 2)) / (n - 1) <= FORCE_SCATTER_LIMIT * power


def period_problems(force, response, period, offset: int = 0, step: int = 1, realisations: int = 1) -> list[str]:
    """Periods of a record that do not repeat, in words (empty when every period is alike).

    Parameters
    ----------
    force : array_like, shape (n_samples, m)
        Forces.
    response : array_like, shape (n_samples, l)
        Responses (e.g. displacements).
    period : int or None
        Samples per period.
    offset, step : int
        The messages name sample ``offset + step * k`` for sample k of the arrays (the window's
        first sample in the file and the decimation factor).

    Returns
    -------
    list of str
        One sentence per problem: the force scatters between periods by more than
        ``FORCE_SCATTER_LIMIT`` of its power (the period is not the force's, or the window spans
        realisations); else each period (1-based) whose response deviates from the period mean by
        more than ``PERIOD_OUTLIER_LIMIT`` times the median period's power (each channel scaled
        by its own deviation), with a hint at the likely cause. Nothing with fewer than three
        whole periods (two periods deviate equally by construction) or without a period.
    realisations : int
        Equal-length realisations one after the other (``Signals.realisations``): each is checked on
        its own (their boundaries are declared, not a problem) and its problems name it.
    """
    if not period:
        return []
    period = int(period)
    f = np.asarray(force, dtype=float)
    y = np.asarray(response, dtype=float)
    f, y = f.reshape(len(f), -1), y.reshape(len(y), -1)
    if int(realisations) > 1:
        length = len(f) // int(realisations)
        return [f"realisation {r + 1}: {problem}" for r in range(int(realisations))
                for problem in period_problems(f[r * length : (r + 1) * length], y[r * length : (r + 1) * length],
                                               period, offset + step * r * length, step)]
    n = len(f) // period
    if n < 3:
        return []
    fp = f[: n * period].reshape(n, period, -1)
    f_mean = fp.mean(axis=0)
    power = float(np.sum((f_mean - f_mean.mean(axis=0)) ** 2))
    scatter = float(np.sum((fp - f_mean) ** 2)) / (n - 1)
    if power <= 0 or scatter > FORCE_SCATTER_LIMIT * power:
        ratio = np.inf if power <= 0 else scatter / power
        found = repeating_period(f)
        hint = f"; it repeats every {found} samples" if found and found != period else ""
        return [
            f"the force does not repeat every {period} samples (its scatter between the {n} periods is "
            f"{ratio:.3g} of its power, limit {FORCE_SCATTER_LIMIT:g}){hint}: check [data] period and that the "
            "window holds one realisation of the excitation"
        ]
    dev = period_deviations(y, period)
    assert dev is not None  # three or more whole periods
    scale = np.sqrt(np.mean(dev**2, axis=(0, 1)))
    scale[scale == 0] = 1.0
    per_period = np.sum((dev / scale) ** 2, axis=(1, 2))
    median = float(np.median(per_period))
    if median <= 0:
        return []
    odd = np.flatnonzero(per_period > PERIOD_OUTLIER_LIMIT * median)
    out = []
    for k in odd:
        where = ("the first period: a transient - start the window one period later" if k == 0
                 else "a transient or the start of another realisation - end the window before it"
                 if k == n - 1 else "not in steady state or disturbed")
        out.append(
            f"period {k + 1} of {n} (samples [{offset + step * k * period}, {offset + step * (k + 1) * period})) "
            f"deviates from "
            f"the period mean {per_period[k] / median:.3g}x as much as the median period ({where}); the "
            "frequency route would count that as noise"
        )
    return out
