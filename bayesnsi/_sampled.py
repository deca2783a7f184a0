"""Input checks and array helpers shared by the sensor conversions of :mod:`bayesnsi.preprocess`.

numpy only. Every check raises :class:`~bayesnsi.exceptions.InputDataError` with a one-line
message naming the bad value.
"""

from __future__ import annotations

import math

import numpy as np

from .exceptions import InputDataError


def real_array(values, name: str) -> np.ndarray:
    """A new float64 array of ``values``, refusing what a float conversion would silently change.

    Refused with :class:`~bayesnsi.exceptions.InputDataError` naming ``name``: complex values
    (their imaginary part would be dropped), booleans, text and other objects, a masked array
    with masked samples (the mask would be ignored), and an array with no samples.

    Parameters
    ----------
    values : array_like
        Real numbers (integers or floats, any shape).
    name : str
        The argument's name, for messages.

    Returns
    -------
    ndarray of float64
        A copy (the input is never modified).
    """
    if np.ma.isMaskedArray(values):
        masked = int(np.ma.getmaskarray(values).sum())
        if masked:
            raise InputDataError(
                f"{name} is a masked array with {masked} masked value(s); bayesnsi does not skip masked samples - "
                "fill or cut them out first (e.g. values.filled(...) on a clean segment)"
            )
        values = np.ma.getdata(values)
    try:
        found = np.asarray(values)
    except (TypeError, ValueError) as err:
        raise InputDataError(f"{name} is not an array of numbers ({err})") from None
    kind = found.dtype.kind
    if kind == "c":
        raise InputDataError(f"{name} holds complex numbers; give real values (e.g. the real part, if that is meant)")
    if kind == "b":
        raise InputDataError(f"{name} holds booleans, not numbers")
    if kind not in "fiu":
        try:
            converted = np.array(found, dtype=float, copy=True)
        except (TypeError, ValueError):
            raise InputDataError(f"{name} must hold real numbers, got an array of {found.dtype}") from None
        if kind == "O" and any(isinstance(v, (bool, complex, np.bool_, np.complexfloating)) for v in found.flat):
            raise InputDataError(f"{name} must hold real numbers (it holds booleans or complex numbers)")
        found = converted
    if found.size == 0 or (found.ndim >= 1 and found.shape[0] == 0):
        raise InputDataError(f"{name} holds no samples (shape {found.shape})")
    return np.array(found, dtype=float, copy=True)


class Columns:
    """An input array as float (n, c) plus how to give results back the same shape."""

    def __init__(self, values, name: str):
        arr = real_array(values, name)
        if arr.ndim not in (1, 2):
            raise InputDataError(f"{name} must have shape (n_samples,) or (n_samples, n_channels), got {arr.shape}")
        self.squeeze = arr.ndim == 1
        self.array = arr.reshape(arr.shape[0], -1)
        if self.array.shape[0] < 8:
            raise InputDataError(f"{name} needs at least 8 samples, got {self.array.shape[0]}")
        bad = ~np.isfinite(self.array)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise InputDataError(
                f"{name} holds {int(bad.sum())} NaN/Inf value(s), the first at sample {row}, channel {col}; "
                "fill or cut them out first"
            )

    def restore(self, out: np.ndarray) -> np.ndarray:
        out = np.ascontiguousarray(out)
        return out[:, 0].copy() if self.squeeze else out


def as_columns(values, name: str) -> Columns:
    return Columns(values, name)


def poly_detrend(x: np.ndarray, order: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if order == 0 or n < 2:
        return x - x.mean(axis=0)
    tau = np.linspace(-1.0, 1.0, n)
    basis = np.polynomial.legendre.legvander(tau, order)
    coef, *_ = np.linalg.lstsq(basis, x.reshape(n, -1), rcond=None)
    return x - (basis @ coef).reshape(x.shape)


def check_fs(fs) -> float:
    if isinstance(fs, bool) or not isinstance(fs, (int, float, np.floating, np.integer)) or not (
        math.isfinite(fs) and fs > 0
    ):
        raise InputDataError(f"fs must be a positive number of Hz, got {fs!r}")
    return float(fs)


def check_band(band, fs: float, allow_dc: bool) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in band)
    except (TypeError, ValueError):
        raise InputDataError(f"band_hz must be a pair (f_lo, f_hi) in Hz, got {band!r}") from None
    low_ok = lo >= 0 if allow_dc else lo > 0
    if not (math.isfinite(lo) and math.isfinite(hi) and low_ok and lo < hi):
        need = "0 <= f_lo < f_hi" if allow_dc else "0 < f_lo < f_hi (f_lo > 0: integration needs a high-pass)"
        raise InputDataError(f"band_hz must satisfy {need}, got {band!r}")
    if lo >= fs / 2:
        raise InputDataError(f"band_hz f_lo = {lo} Hz must be below the Nyquist frequency {fs / 2} Hz")
    return lo, hi


def check_taper(taper) -> None:
    if isinstance(taper, bool) or not isinstance(taper, (int, float)) or not 0 <= taper < 1:
        raise InputDataError(f"taper must be a number in [0, 1), got {taper!r}")


def check_int(value, name: str, minimum: int) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputDataError(f"{name} must be an integer >= {minimum}, got {value!r}")
