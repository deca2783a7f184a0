"""Sub-record windows of a record, re-identified: the ``"segments"`` intervals (docs/method.md §11).

``n_segments`` windows of ``b = segment_fraction · N`` samples are re-identified with the full
record's order and band; for an error variance ``σ²/b`` the full-record variance is
``b/(N - b) · mean_w (θ_w - θ_N)²`` (delete-d jackknife, :func:`scatter_sd`). The windows overlap,
so that variance carries about 2.7 degrees of freedom whatever their number; the noise and model
replicates (:mod:`.replicates`, :mod:`.surrogate`) are the default for that reason. A record of
several realisations is cut into them instead.
"""

from __future__ import annotations

import numpy as np

from .replicates import reidentify

__all__ = ["scatter_sd", "segment_estimates"]

_MAX_FRACTION = 0.9  # windows are lengthened to what the block rows need, up to this fraction of the record


def segment_estimates(result, signals, options=None, n_segments: int = 8, fraction: float = 0.7):
    """Re-identify a candidate on ``n_segments`` sub-records of ``fraction`` of the record.

    Parameters
    ----------
    result : NSIResult
        The full-record identification (its order and band are kept for the sub-records).
    signals : Signals
        The estimation data it came from.
    options : NSIOptions, optional
        Its identification settings (default ``NSIOptions()``).
    n_segments : int
        Number of sub-records, at evenly spaced offsets.
    fraction : float
        Length of a sub-record as a fraction of the record, in (0, 1); lengthened to what the
        block rows need for this candidate, up to 90 % of the record. A record of several
        ``realisations`` is cut into them instead (``n_segments`` and ``fraction`` unused).

    Returns
    -------
    samples : int
        Samples per sub-record.
    coefficients : ndarray, shape (n_ok, q)
        Coefficients of each sub-record identified successfully.
    frequencies, damping_ratios : ndarray, shape (n_ok, n_modes)
        Its modes matched to the full-record modes (NaN where none is within 10 % in frequency).
    failures : list of str
        One message per sub-record that failed.
    """
    from ..options import NSIOptions

    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must lie in (0, 1), got {fraction!r}")
    options = (options or NSIOptions()).replace(order=result.order, band_hz=tuple(result.band_hz))
    n = signals.n_samples
    if signals.realisations > 1:  # the realisations themselves: their scatter holds the distortion
        records = enumerate(signals.realisation_records(), start=1)
        return (n // signals.realisations, *reidentify(result, ((f"realisation {k}", s) for k, s in records), options))
    b = max(int(round(fraction * n)), min(_shortest_window(result), int(_MAX_FRACTION * n)))
    offsets = np.unique(np.linspace(0, n - b, n_segments).round().astype(int))
    windows = ((f"samples {o}..{o + b}", signals.segment(int(o), int(o) + b)) for o in offsets)
    return (b, *reidentify(result, windows, options))


def _shortest_window(result) -> int:
    """Fewest data samples the block rows accept for this candidate's extended input and outputs."""
    channels = result.model.B.shape[1] + result.model.C.shape[0]
    needed = 2 * int(result.block_rows) * (channels + 1) - 1  # on the identification grid
    return -(-needed // max(int(result.upsample), 1)) + 1


def scatter_sd(windows: np.ndarray, full: np.ndarray, samples: int, n: int) -> np.ndarray:
    """``sqrt(b/(N-b) · mean_w (θ_w - θ_N)²)`` per column (NaN where fewer than 2 windows).

    Parameters
    ----------
    windows : ndarray, shape (n_windows, p)
        Estimates on the windows.
    full : ndarray, shape (p,)
        The full-record estimates.
    samples : int
        Samples per window, b.
    n : int
        Samples of the record, N.

    Returns
    -------
    ndarray, shape (p,)
    """
    dev2 = (windows - full[None, :]) ** 2
    count = np.sum(np.isfinite(dev2), axis=0)
    with np.errstate(invalid="ignore"):
        mean = np.nansum(dev2, axis=0) / np.maximum(count, 1)
    return np.where(count >= 2, np.sqrt(samples / (n - samples) * mean), np.nan)
