"""Units of an experiment's channels, as the data file or the config state them, for labels.

Units are reported, never converted (:mod:`bayesnsi.io.measurements`). A CSV file states them in
its units row (the line after the header), a UFF58 file in its ordinate labels; MATLAB and HDF5
files state none; ``[data] units = { column = "unit" }`` in the config states or overrides them.
A channel whose unit is not stated is labelled "data units".
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ._columns import file_format
from ._csv import _read_head, _units

__all__ = ["ChannelUnits", "data_units", "term_unit"]

UNSTATED = ""


@dataclass(frozen=True)
class ChannelUnits:
    """Units of the force, displacement and velocity channels ("" where the file states none).

    Attributes
    ----------
    force, displacement, velocity : str
    """

    force: str = UNSTATED
    displacement: str = UNSTATED
    velocity: str = UNSTATED

    @staticmethod
    def _show(unit: str) -> str:
        return unit if unit else "data units"

    @property
    def frf(self) -> str:
        """Unit of a displacement-per-force FRF, e.g. ``"m/N"`` (``"data units"`` when unknown)."""
        if self.force and self.displacement:
            return f"{self.displacement}/{_group(self.force)}"
        return "data units"

    def label(self, quantity: str) -> str:
        """``"[m]"``-style bracket for ``"force"``, ``"displacement"``, ``"velocity"`` or ``"frf"``.

        Parameters
        ----------
        quantity : str

        Returns
        -------
        str
        """
        unit = self.frf if quantity == "frf" else self._show(getattr(self, quantity))
        return f"[{unit}]"


def data_units(config) -> ChannelUnits:
    """The units the ``[data]`` file of a config states for its force and response channels.

    Reads only the header and units row of a CSV file (a UFF58 file is read whole for its labels);
    ``[data] units`` overrides them, and a column with a ``[data] scale`` gain keeps only a unit the
    config states (the gain changes it). With ``integrate``, the displacement unit is the
    acceleration unit without its ``/s²`` (the velocity unit without its ``/s``).

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    ChannelUnits
        Empty strings for what the file does not state, or when the channels of one kind
        disagree (the loader refuses that anyway).
    """
    data = config.data
    stated = {column: unit for column, unit in _stated_units(data).items() if column not in data.scale}
    stated |= dict(getattr(data, "units", {}) or {})  # the config's [data] units win
    force = _common(stated, data.inputs)
    if data.integrate is not None and data.accelerations:
        acceleration = _common(stated, data.accelerations)
        displacement = re.sub(r"\s*/\s*s(\^2|²|2|\*\*2)$", "", acceleration) if acceleration else UNSTATED
        displacement = displacement if displacement != acceleration else UNSTATED
        velocity = f"{displacement}/s" if displacement else UNSTATED
    elif data.integrate is not None:  # velocity sensors: the displacement unit is theirs without its /s
        velocity = _common(stated, data.velocities or {})
        displacement = re.sub(r"\s*/\s*s$", "", velocity) if velocity else UNSTATED
        displacement = displacement if displacement != velocity else UNSTATED
    else:
        displacement = _common(stated, data.outputs)
        velocity = _common(stated, data.velocities or {}) or (f"{displacement}/s" if displacement else UNSTATED)
    return ChannelUnits(force=force, displacement=displacement, velocity=velocity)


def term_unit(expr: str, units: ChannelUnits) -> str:
    """Unit of a nonlinear term's coefficient λ: force unit over the unit of n(x, v), when it is a product.

    Handles products and integer powers of ``x<k>``, ``v<k>``, ``abs(...)`` of them and ``sign``/``tanh``
    (unitless), e.g. ``v1*abs(v1)`` -> ``N/(m/s)^2`` and ``x1**3`` -> ``N/m^3``, and a Bouc-Wen
    variable (``boucwen(x1, ...)`` -> ``N/m``); anything else (sums, clearances) gives ``""``.

    Parameters
    ----------
    expr : str
        The term's expression text.
    units : ChannelUnits

    Returns
    -------
    str
        ``""`` when the unit cannot be read off the expression or the data units are unknown.
    """
    if not units.force or not units.displacement:
        return UNSTATED
    text = re.sub(r"\s+", "", expr).replace("**", "^")
    # a Bouc-Wen variable z has the unit of the displacement it follows: λ is a stiffness
    text = re.sub(r"boucwen\(\(?([^(),]*?)\)?,[^()]*\)", lambda m: f"({m[1]})" if "-" in m[1] else m[1], text)
    text = re.sub(r"\(([xv])\d+-\1\d+\)", r"\g<1>0", text)  # relative motion across an element
    text = re.sub(r"(sign|tanh)\([^()]*\)", "1", text)  # unitless factors
    text = re.sub(r"abs\(([xv]\d+)\)", r"\1", text)
    exponents = {"x": 0, "v": 0}
    for factor in text.split("*"):
        match = re.fullmatch(r"([xv])\d+(?:\^(\d+))?|\d+(?:\.\d*)?", factor)
        if match is None:
            return UNSTATED
        if match.group(1):
            exponents[match.group(1)] += int(match.group(2) or 1)
    parts = []
    for kind, unit in (("x", units.displacement), ("v", units.velocity)):
        power = exponents[kind]
        if power:
            parts.append(_group(unit) + (f"^{power}" if power > 1 else ""))
    if not parts:
        return units.force
    below = "·".join(parts)
    return f"{units.force}/({below})" if len(parts) > 1 else f"{units.force}/{below}"


def _group(unit: str) -> str:
    return f"({unit})" if "/" in unit or " " in unit else unit


def _stated_units(data) -> dict:
    if getattr(data, "files", None):  # one file per channel ([data] files): no units row; [data] units labels
        return {}
    kind = file_format(data.file)
    if kind == "csv":
        header, first_row = _read_head(data.file)
        return _units(header, first_row)
    if kind == "uff":
        from .measurements import read_columns

        names = [*data.inputs, *(data.outputs or {}), *(data.velocities or {}), *(data.accelerations or {})]
        return dict(read_columns(data.file, names).units)
    return {}


def _common(stated: dict, columns) -> str:
    found = {stated.get(name, "").strip() for name in columns or ()}
    return found.pop() if len(found) == 1 else UNSTATED
