"""One measurement file mapped by ``[data]``, and the processing of a window of it into
:class:`~bayesnsi.signals.Signals`: cut -> integrate -> decimate -> remove means."""

from __future__ import annotations

import re
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import preprocess
from ..exceptions import ConfigError, InputDataError, IntegrationWarning, PeriodicityWarning
from ..noise import AccelerationNoise, acceleration_noise_std, edge_samples
from ..noise.lowband import below_band_messages, noise_edge_messages
from ..nsi.periodic import periodic_integration
from ..nsi.steady import period_problems
from ..signals import Signals
from ._columns import MeasurementColumns, file_format
from ._csv import read_csv_any
from ._formats import read_matlike
from ._realisations import Split, joined, split_parts
from ._specs import DataSpec
from ._split import read_split
from ._uff import read_uff

__all__ = ["Record", "read_any"]

_Window = tuple[np.ndarray, np.ndarray, "np.ndarray | None"]  # force, displacement, velocity


class Record:
    """The mapped channels of one file (raw, may hold NaN until a window is checked).

    Parameters
    ----------
    path : Path
        The measurement file (any supported format).
    data : DataSpec
        Column -> DOF maps, sampling and processing (``[data]``).
    files : mapping of str to Path, optional
        Each column in a file of its own (``[data] files`` or a validation segment's
        ``files``; :mod:`bayesnsi.io._split`); ``path`` is then only named in messages.

    Raises
    ------
    InputDataError
        As :func:`bayesnsi.io.read_signals`.
    """

    def __init__(self, path: Path, data: DataSpec, files: Mapping[str, Path] | None = None):
        self.path = Path(path)
        self.data = data
        self.integrate = data.integrate
        if self.integrate is not None:
            responses = {c: str(data.integrated) for c in data.sensor_columns}
        else:
            responses = {c: "displacement" for c in data.outputs}
            responses.update({c: "velocity" for c in data.velocities or {}})
        roles = {c: "input" for c in data.inputs} | responses
        present = {} if self.integrate is not None else {c: "acceleration" for c in data.accelerations}
        if files:  # one file per channel ([data] files): read_split checks that each holds its channel
            table = read_split({c: files[c] for c in roles}, roles, data.time_column, read_any)
        else:
            table = read_any(self.path, list(roles), roles, data.time_column, present)
        self.table = table
        self.fs = _resolve_fs(table, data)
        _check_units(table, roles, data.units)
        self.force = _stack(table, data.inputs, data.scale)
        # accelerations or velocities with integrate, else displacements (and measured velocities, in output order)
        self.velocity_columns: list[str] = []
        if self.integrate is not None:
            self.response_columns = list(data.sensor_columns)
        else:
            self.response_columns = list(data.outputs)
            by_dof = {dof: column for column, dof in (data.velocities or {}).items()}
            self.velocity_columns = [by_dof[dof] for dof in data.outputs.values()] if by_dof else []
        self.response = _stack(table, self.response_columns, data.scale)
        self.velocity = _stack(table, self.velocity_columns, data.scale) if self.velocity_columns else None
        self._cache: dict[tuple[int, int], _Window] = {}

    @property
    def n_samples(self) -> int:
        """Number of samples in the file."""
        return self.force.shape[0]

    def check_same_units(self, other: Record, what: str) -> None:
        """Refuse ``other`` (a validation record) where its file states another unit for a mapped column.

        Raises
        ------
        InputDataError
            Naming the column and both units (e.g. accelerations in g in one file, m/s² in the other).
        """
        for name in [*self.data.inputs, *self.response_columns, *self.velocity_columns]:
            # the files' own units rows, whatever [data] units labels (a label converts nothing, nor does a
            # [data] scale gain, which multiplies every file alike)
            mine, theirs = self.table.units.get(name, "").strip(), other.table.units.get(name, "").strip()
            if mine and theirs and normalized_unit(mine) != normalized_unit(theirs):
                raise InputDataError(
                    f"{what}: {other.path.name} states {theirs!r} for column {name!r} where the estimation file "
                    f"{self.path.name} states {mine!r}; one model needs one unit per channel - convert one of the "
                    "files, or give the validation data in the estimation file's units"
                )

    def window(self, bounds, key: str, config_path: Path) -> tuple[int, int]:
        """``[start, stop)`` of ``bounds`` (None: the whole record), checked against the record."""
        start, stop = bounds if bounds is not None else (None, None)
        start = 0 if start is None else start
        stop = self.n_samples if stop is None else stop
        if stop > self.n_samples or start >= stop:
            raise ConfigError(
                f"{config_path}: {key}: expected a window inside the record of {self.n_samples} samples "
                f"in {self.path.name}, found [{start}, {stop}); shrink the window"
            )
        return start, stop

    def means(self, start: int, stop: int, split: Split | None = None) -> _Window:
        """Mean of each processed channel group over the window (over the steady parts of its realisations)."""
        parts = split_parts(self.data.period, self.path, start, stop, split)
        force, displacement, velocity = joined([self._processed(a, b) for a, b in parts])
        return force.mean(axis=0), displacement.mean(axis=0), None if velocity is None else velocity.mean(axis=0)

    def signals(self, start: int, stop: int, means: _Window | None, split: Split | None = None) -> Signals:
        """The processed window as Signals, with ``means`` (if given) subtracted; with ``split`` cut into its
        realisations without their transient periods, each processed on its own (:mod:`._realisations`)."""
        parts = split_parts(self.data.period, self.path, start, stop, split)
        force, displacement, velocity = joined([self._processed(a, b) for a, b in parts])
        if means is not None:
            force, displacement = force - means[0], displacement - means[1]
            velocity = None if velocity is None or means[2] is None else velocity - means[2]
        period = _period(self.data, len(force) // len(parts))
        n = len(force) // len(parts)
        for r, (a, b) in enumerate(parts):  # each realisation on its own: their boundaries are declared
            name = f"realisation {r + 1} of {len(parts)}, " if len(parts) > 1 else ""
            for problem in period_problems(force[r * n : (r + 1) * n], displacement[r * n : (r + 1) * n], period, a,
                                           self.data.decimate):  # else: "noise"
                warnings.warn(f"{self.path}: {name}samples [{a}, {b}): {problem}", PeriodicityWarning, stacklevel=2)
        return Signals(
            force=force, displacement=displacement, velocity=velocity,
            fs=self.fs / self.data.decimate,
            input_dofs=tuple(self.data.inputs.values()), output_dofs=tuple(self.data.outputs.values()),
            input_names=tuple(self.data.inputs), output_names=tuple(self.data.outputs),
            period=period, realisations=len(parts),
            measured=self._measured,
            acceleration_noise=self._acceleration_noise(start, stop),
        )

    @property
    def _measured(self) -> str:
        """What the response sensors measure: "displacement", or what ``integrate`` integrates."""
        return self.data.integrated or "displacement"

    def _acceleration_noise(self, start: int, stop: int) -> AccelerationNoise | None:
        """The sensors' white noise and the recipe of a window integrated in time (None otherwise).

        Declared (``integrate.noise_std``, times each column's scale) or estimated on the measured
        accelerations (or velocities) of the window before integration (:mod:`bayesnsi.noise.accelerometer`); whole
        periods, integrated line by line, take their noise from the period scatter instead.
        """
        spec = self.integrate
        if spec is None or self.data.period is not None:
            return None
        if spec.noise_std is not None:
            gains = self.data.scale or {}
            std = [abs(spec.noise_std * gains.get(c, 1.0)) for c in self.response_columns]
        else:
            std = list(acceleration_noise_std(self.response[start:stop], self.fs, self.force[start:stop],
                                              spec.band_hz[0]))
        for message in noise_edge_messages(self.response[start:stop], std, self.fs, spec.band_hz,
                                           self.response_columns, self._measured):
            warnings.warn(f"{self.path.name}: {message}", IntegrationWarning, stacklevel=3)
        return AccelerationNoise(
            acceleration_std=tuple(std), fs=self.fs, band_hz=spec.band_hz, method=spec.method, taper=spec.taper,
            filter_order=spec.filter_order, detrend_order=spec.detrend_order, decimate=self.data.decimate,
            source="estimated" if spec.noise_std is None else "declared",
            trim=self._trimmed_edge(-(-(stop - start) // self.data.decimate)), measured=self._measured,
        )

    def _trimmed_edge(self, n_samples: int, where: str = "") -> int:
        """Samples dropped at each end of a window integrated in time with ``trim_edges`` (0 otherwise).

        A window too short to keep half of it is kept whole, with an IntegrationWarning when ``where`` is given.
        """
        spec = self.integrate
        if spec is None or self.data.period is not None or not spec.trim_edges:
            return 0
        fs = self.fs / self.data.decimate
        edge = edge_samples(spec.band_hz, spec.taper, fs)
        if n_samples > 4 * edge:
            return edge
        if where:
            warnings.warn(
                f"{self.path.name}: {where}: too short to drop the integration's edges ({edge / fs:.3g} s = "
                f"2/(taper f_lo) at each end of {n_samples / fs:.3g} s), kept whole: the integrated motion near its "
                "ends misses the acceleration outside it; give a longer window or a higher f_lo",
                IntegrationWarning, stacklevel=3,
            )
        return 0

    def _processed(self, start: int, stop: int) -> _Window:
        """Window [start, stop) of the file, integrated and decimated as [data] asks (cached)."""
        key = (start, stop)
        if key in self._cache:
            return self._cache[key]
        self._check_finite(start, stop)
        force = self.force[start:stop]
        velocity: np.ndarray | None
        spec = self.integrate
        try:
            if spec is not None and self.data.period is not None:  # whole periods: exact line by line, in band
                velocity, displacement = periodic_integration(
                    self.response[start:stop], self.fs, self.data.period, spec.band_hz, self._measured
                )
            elif spec is not None:
                for message in below_band_messages(force, self.response[start:stop], self.fs, spec.band_hz,
                                                   self.response_columns, self._measured):
                    warnings.warn(f"{self.path.name}: {message}", IntegrationWarning, stacklevel=2)
                velocity, displacement = preprocess.integrate_measured(
                    self.response[start:stop], self._measured, self.fs, spec.band_hz, spec.method,
                    detrend_order=spec.detrend_order, taper=spec.taper, filter_order=spec.filter_order,
                )
                if spec.filter_inputs:
                    force = preprocess.band_filter(
                        force, self.fs, spec.band_hz, spec.method, taper=spec.taper, filter_order=spec.filter_order
                    )
            else:
                displacement = self.response[start:stop]
                velocity = None if self.velocity is None else self.velocity[start:stop]
            q = self.data.decimate
            if q > 1:
                force, displacement = preprocess.decimate(force, q), preprocess.decimate(displacement, q)
                velocity = None if velocity is None else preprocess.decimate(velocity, q)
            edge = self._trimmed_edge(len(force), f"samples [{start}, {stop})")
            if edge:  # integrate.trim_edges: the integration's edge error left out of every window
                force, displacement = force[edge:-edge], displacement[edge:-edge]
                velocity = None if velocity is None else velocity[edge:-edge]
        except InputDataError as exc:
            raise InputDataError(f"{self.path}: samples [{start}, {stop}): {exc}") from exc
        self._cache[key] = (force, displacement, velocity)
        return self._cache[key]

    def _check_finite(self, start: int, stop: int) -> None:
        groups = [(list(self.data.inputs), self.force), (self.response_columns, self.response)]
        if self.velocity is not None:
            groups.append((self.velocity_columns, self.velocity))
        for names, values in groups:
            bad = ~np.isfinite(values[start:stop])
            if bad.any():
                row, col = np.argwhere(bad)[0]
                raise InputDataError(
                    f"{self.path}: column {list(names)[col]!r} has {int(bad.sum())} missing or non-finite value(s) "
                    f"in samples [{start}, {stop}), the first at sample {start + row}"
                    f"{self.table.locate(start + row)}; fill or remove them, or choose a window that excludes them"
                )


def _period(data: DataSpec, n_samples: int) -> int | None:
    """Samples per period of the loaded signals; None for a window shorter than one period."""
    if data.period is None or n_samples < data.period // data.decimate:
        return None
    return data.period // data.decimate


def read_any(path: Path, columns: list[str], roles: Mapping[str, str], time_column: str,
             present: Mapping[str, str]) -> MeasurementColumns:
    """Read ``columns`` of any supported file; check that the ``present`` ones exist."""
    kind = file_format(path)
    if not path.is_file():
        raise InputDataError(f"data file {path} not found; check the name and folder")
    if kind == "csv":
        return read_csv_any(path, columns, time_column, present)
    if kind == "uff":
        return read_uff(path, columns, roles, present)
    return read_matlike(path, columns, time_column, present)


def _resolve_fs(table: MeasurementColumns, data: DataSpec) -> float:
    if table.fs is None:
        if data.fs is None:
            raise InputDataError(f"{table.path}: no sampling frequency - [data] fs is not set and {table.hint}")
        return data.fs
    if data.fs is not None and abs(table.fs - data.fs) > table.fs_tolerance * data.fs:
        fix = "correct fs, or drop it to use the " + ("time column" if table.format == "csv" else table.fs_source)
        raise InputDataError(
            f"{table.path}: {table.fs_source} gives fs = {table.fs:.9g} Hz but [data] fs = {data.fs:g} Hz; {fix}"
        )
    return data.fs if data.fs is not None else table.fs


_LENGTH = r"(?:m|mm|cm|um|µm|μm|nm|in|ft)"
_QUANTITY_OF_UNIT = (  # "g" is gravity here: a gram is no displacement or velocity either
    (re.compile(rf"{_LENGTH}/s\^2|m?g|gn", re.IGNORECASE), "acceleration"),
    (re.compile(rf"{_LENGTH}/s", re.IGNORECASE), "velocity"),
    (re.compile(_LENGTH, re.IGNORECASE), "displacement"),
)


def normalized_unit(unit: str) -> str:
    """One spelling of a unit label: "m/s2", "m/s²", "m s^-2", "m/s/s" and "m/s**2" all give "m/s^2".

    Parameters
    ----------
    unit : str

    Returns
    -------
    str
    """
    text = "".join(unit.split()).replace("²", "^2").replace("**", "^").replace("·", "").replace("*", "")
    text = re.sub(r"/s/s$", "/s^2", text)
    text = re.sub(r"(?<=[a-zµμ])s\^-2$", "/s^2", text)
    text = re.sub(r"(?<=[a-zµμ])s\^-1$", "/s", text)
    return re.sub(r"/s2$", "/s^2", text)


_KEY_OF_ROLE = {"displacement": "outputs", "velocity": "velocities", "acceleration": "accelerations"}


def quantity_of_unit(unit: str) -> str | None:
    """The response quantity a unit label names unambiguously ("m/s^2" -> "acceleration"), else None.

    Parameters
    ----------
    unit : str
        A unit label, e.g. from a CSV file's units row.

    Returns
    -------
    {"displacement", "velocity", "acceleration"} or None
    """
    text = normalized_unit(unit)
    for pattern, quantity in _QUANTITY_OF_UNIT:
        if pattern.fullmatch(text):
            return quantity
    return None


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def _check_units(table: MeasurementColumns, roles: Mapping[str, str], stated: Mapping[str, str] | None = None) -> None:
    """Channels of one response kind must share a unit where the file states units, and a unit that
    names another quantity than the channel's role (m/s under ``accelerations``) is refused.

    ``stated`` (``[data] units``) overrides the file's units row, e.g. to correct a wrong one.
    """
    by_role: dict[str, dict[str, str]] = {}
    for name, role in roles.items():
        unit = (stated or {}).get(name) or table.units.get(name, "").strip()
        if unit and role != "input":
            by_role.setdefault(role, {})[name] = unit
            quantity = quantity_of_unit(unit)
            if quantity is not None and quantity != role:
                raise InputDataError(
                    f"{table.path}: column {name!r} is in {unit!r}, {_article(quantity)} {quantity}, but [data] "
                    f"maps it under {_KEY_OF_ROLE[role]} ({_article(role)} {role}); map it under "
                    f"{_KEY_OF_ROLE[quantity]}"
                    f"{' with integrate = { band_hz = [f_lo, f_hi] }' if quantity != 'displacement' else ''}, or, if "
                    f'the file\'s unit is wrong, state the right one with [data] units = {{ {name} = "..." }}'
                )
    for role, units in by_role.items():
        if len({normalized_unit(u) for u in units.values()}) > 1:
            raise InputDataError(
                f"{table.path}: the {role} channels are in different units "
                f"({', '.join(f'{name!r}: {unit[:20]!r}' for name, unit in units.items())}); one model needs one unit "
                "per quantity - convert them to a common unit before loading"
            )


def _stack(table, columns, scale=None) -> np.ndarray:
    """The columns side by side, each times its ``[data] scale`` factor (1 when not given)."""
    gains = scale or {}
    return np.column_stack([table.values[c] * gains.get(c, 1.0) for c in columns])
