"""What every measurement reader shares: formats, :class:`MeasurementColumns`, the checks of
lengths and sampling, vectors, and the import of the optional readers h5py and pyuff (a missing
one is an error naming the extra that installs it). It imports no reader, so that
:mod:`bayesnsi.io._csv`, :mod:`bayesnsi.io._formats`, :mod:`bayesnsi.io._uff` and
:mod:`bayesnsi.io.measurements` all sit above it.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import InputDataError

__all__ = [
    "EXTRAS",
    "FORMATS",
    "FS_TOLERANCE",
    "TIME_TOLERANCE",
    "MeasurementColumns",
    "file_format",
]

TIME_TOLERANCE = 0.01
"""Largest allowed deviation of a time stamp from the uniform grid, as a fraction of 1/fs."""

FS_TOLERANCE = 1e-4
"""Largest relative difference between ``[data] fs`` and a rate stored in the file as a number
(a scalar ``fs`` variable, UFF ``abscissa_inc``, which pyuff writes with 6 significant digits)."""

FORMATS = {".mat": "mat", ".h5": "hdf5", ".hdf5": "hdf5", ".uff": "uff", ".unv": "uff"}
"""File extension (lower case) -> format; every other extension is read as CSV text."""

_SHOWN_NAMES = 40
_SHOWN_CHARS = 40


def file_format(path: str | os.PathLike) -> str:
    """The format a file is read as, from its extension.

    Parameters
    ----------
    path : str or path-like
        The measurement file.

    Returns
    -------
    str
        "csv", "mat", "hdf5" or "uff" (:data:`FORMATS`; any other extension is CSV text).
    """
    return FORMATS.get(Path(path).suffix.lower(), "csv")


@dataclass(frozen=True)
class MeasurementColumns:
    """Some channels of a measurement file of any supported format, as read.

    Parameters
    ----------
    path : Path
        The file.
    format : {"csv", "mat", "hdf5", "uff"}
    names : tuple of str
        Every channel the file offers: CSV header names, MAT/HDF5 variable names, or UFF58
        records as ``"'id1' (node:dir)"``.
    values : dict of str to ndarray, shape (n_samples,)
        The channels asked for, as float arrays, under the names used to ask for them.
    units : dict of str to str
        Units stated in the file (CSV units row, UFF ordinate units label); may be empty.
    fs : float or None
        Sampling frequency stored in the file [Hz] (time column/vector, scalar ``fs``,
        UFF ``abscissa_inc``); None when the file has none.
    fs_source : str
        Where ``fs`` came from, for messages.
    fs_tolerance : float
        Relative tolerance when ``fs`` is compared with ``[data] fs``.
    first_line : int or None
        CSV only: line number (1-based) of the first sample.
    hint : str
        What to do when the file has no sampling information.
    """

    path: Path
    format: str
    names: tuple[str, ...]
    values: dict[str, np.ndarray]
    units: dict[str, str]
    fs: float | None
    fs_source: str = ""
    fs_tolerance: float = FS_TOLERANCE
    first_line: int | None = None
    hint: str = "set fs in [data]"

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return len(next(iter(self.values.values()))) if self.values else 0

    def locate(self, sample: int) -> str:
        """Where sample ``sample`` is in the file, for messages (a CSV line number, else empty)."""
        return f" (line {self.first_line + sample})" if self.first_line is not None else ""


def shown_names(names: Iterable[str]) -> str:
    """Channel names for a message: quoted, each and their number bounded, control characters escaped."""
    names = list(names)
    parts = []
    for name in names[:_SHOWN_NAMES]:
        text = repr(name)
        parts.append(text if len(text) <= _SHOWN_CHARS else text[: _SHOWN_CHARS - 4] + "...'")
    more = len(names) - _SHOWN_NAMES
    return ", ".join(parts) + (f" and {more} more" if more > 0 else "") if parts else "none"


def sampling_frequency(t: np.ndarray, where: str, locate, fs: float | None, slack: float = 0.0) -> float:
    """fs from uniformly spaced time stamps [s] (``slack``: extra absolute tolerance [s])."""
    if not np.all(np.isfinite(t)):
        row = int(np.argmax(~np.isfinite(t)))
        raise InputDataError(f"{where} has a missing value at sample {row}{locate(row)}; fill it or set [data] fs")
    if len(t) < 2:
        raise InputDataError(f"{where}: need at least two samples to derive fs")
    dt = (t[-1] - t[0]) / (len(t) - 1)
    deviation = np.abs(t - (t[0] + dt * np.arange(len(t))))
    tolerance = TIME_TOLERANCE * abs(dt) + slack
    if not dt > 0 or np.any(np.diff(t) <= 0) or deviation.max() > tolerance:
        row = int(np.argmax(deviation)) if dt > 0 else 0
        raise InputDataError(
            f"{where} is not uniformly sampled: expected increasing time stamps within {TIME_TOLERANCE:g} of a "
            f"sample interval ({dt:.6g} s) of a uniform grid, found a deviation of {deviation.max():.3g} s at sample "
            f"{row}{locate(row)}; resample the record to a uniform rate"
        )
    derived = 1.0 / dt
    if fs is not None and abs(derived - fs) > 1e-3 * fs:
        raise InputDataError(
            f"{where} gives fs = {derived:.9g} Hz but [data] fs = {fs:g} Hz; correct fs, or drop it to use the "
            "time column"
        )
    return fs if fs is not None else derived


def missing_message(path: Path, what: str, missing, available, hint: str) -> InputDataError:
    """The error for channels a file does not hold, listing (a bounded number of) those it holds."""
    return InputDataError(f"{path}: {what} {missing} not found; available: {shown_names(available)}. {hint}")


def check_lengths(path: Path, values: Mapping[str, np.ndarray], what: str) -> None:
    """All channels must have the same number of samples."""
    lengths = {name: len(v) for name, v in values.items()}
    if len(set(lengths.values())) > 1:
        raise InputDataError(
            f"{path}: the {what} have different lengths {lengths}; all channels must be sampled together - "
            "store them with the same number of samples"
        )


EXTRAS = {"h5py": "hdf5", "pyuff": "uff"}
"""Optional module -> the bayesnsi extra that installs it (``pip install 'bayesnsi[hdf5]'``)."""


def optional_module(module: str, path: Path, what: str):
    """Import an optional reader module, or say which extra installs it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputDataError(
            f"{path}: reading {what} needs {module}, which is not installed; "
            f"pip install 'bayesnsi[{EXTRAS[module]}]'"
        ) from None



def as_vector(value, where: str, kind: str) -> np.ndarray:
    """A 1-D float copy of a vector (1×N, N×1 or N); anything else is an error. ``where`` names it."""
    if hasattr(value, "toarray"):  # scipy.sparse
        raise InputDataError(f"{where} is a sparse matrix; store it as a full numeric vector")
    array = np.asarray(value)
    if array.dtype.kind not in "iuf":
        raise InputDataError(
            f"{where} ({kind}, dtype {array.dtype}) is not a real numeric vector; "
            "store each channel as a real numeric vector of its own"
        )
    if array.size == 0:
        raise InputDataError(f"{where} is empty")
    if array.ndim > 2 or (array.ndim == 2 and min(array.shape) != 1):
        raise InputDataError(
            f"{where} has shape {array.shape}; expected a vector (1×N or N×1) - store each "
            "channel as its own variable"
        )
    return np.array(array.reshape(-1), dtype=float)

