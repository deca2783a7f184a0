"""What a check found, as one typed record that every surface renders the same way.

A :class:`Finding` says what was checked (``kind``, a stable dotted name such as
``"adequacy.none_adequate"``), about what (``subject``: a candidate, a channel or a term; empty for
the record as a whole), how much it matters (``severity``), the numbers behind it (``values``) and
the sentence made from them (``message``). The library returns findings on its results
(:attr:`bayesnsi.selection.Selection.findings`, a candidate's ``findings``, an interval's
``findings``); Python warnings, the terminal, the report and results.json render these same
records, so no surface tells a different story.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .exceptions import BayesNSIWarning

__all__ = ["SEVERITIES", "Finding", "emit", "finding_from_dict", "finding_from_warning", "messages"]

SEVERITIES = ("note", "warning")
"""``"note"``: context that changes no decision; ``"warning"``: what a result should not be trusted for."""

Value = float | int | str | bool | None | tuple


@dataclass(frozen=True)
class Finding:
    """One finding of a check (module notes).

    Parameters
    ----------
    kind : str
        Stable dotted name of the check and outcome, e.g. ``"adequacy.none_adequate"``.
    message : str
        The sentence a person reads, made from ``values``.
    subject : str
        What it is about (a candidate's name, a channel, a term); empty for the whole record.
    severity : {"note", "warning"}
    values : mapping of str to number, str, bool, None or tuple
        The figures the message states (JSON-ready).
    """

    kind: str
    message: str
    subject: str = ""
    severity: str = "warning"
    values: Mapping[str, Value] = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        if self.severity not in SEVERITIES:
            raise ValueError(f"severity must be one of {SEVERITIES}, got {self.severity!r}")
        if not self.kind or not self.message:
            raise ValueError("a finding needs a kind and a message")
        object.__setattr__(self, "values", dict(self.values))

    def __str__(self) -> str:
        return self.message

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record: ``kind``, ``subject``, ``severity``, ``values``, ``message``.

        Returns
        -------
        dict
            Non-finite numbers become None.
        """
        return {"kind": self.kind, "subject": self.subject, "severity": self.severity,
                "values": {k: _plain(v) for k, v in self.values.items()}, "message": self.message}


def finding_from_dict(record: Mapping[str, Any]) -> Finding:
    """A finding from its :meth:`Finding.to_dict` record.

    Parameters
    ----------
    record : mapping

    Returns
    -------
    Finding
    """
    values = {str(k): tuple(v) if isinstance(v, list) else v for k, v in dict(record.get("values") or {}).items()}
    return Finding(kind=str(record["kind"]), message=str(record["message"]), subject=str(record.get("subject", "")),
                   severity=str(record.get("severity", "warning")), values=values)


def messages(findings: Iterable[Finding]) -> tuple[str, ...]:
    """The sentences of some findings, in order.

    Parameters
    ----------
    findings : iterable of Finding

    Returns
    -------
    tuple of str
    """
    return tuple(f.message for f in findings)


def emit(findings: Iterable[Finding], category: type[Warning] = BayesNSIWarning, stacklevel: int = 2) -> None:
    """Issue each warning-severity finding as a Python warning of ``category`` that carries it.

    The warning's text is the finding's message; :func:`finding_from_warning` gets the finding back
    from a caught warning (so a batch that records the warnings of a candidate keeps them typed).

    Parameters
    ----------
    findings : iterable of Finding
    category : type of Warning
    stacklevel : int
        As :func:`warnings.warn` (counted from the caller of ``emit``).
    """
    for finding in findings:
        if finding.severity == "warning":
            warnings.warn(category(finding), stacklevel=stacklevel + 1)


def finding_from_warning(caught: warnings.WarningMessage) -> Finding:
    """The finding a caught warning carries (:func:`emit`), or one made from its text and category.

    Parameters
    ----------
    caught : warnings.WarningMessage
        As recorded by :func:`warnings.catch_warnings` with ``record=True``.

    Returns
    -------
    Finding
        Kind ``"warning.<Category>"`` for a warning that carries no finding.
    """
    message = caught.message
    args: tuple = tuple(getattr(message, "args", ()))
    if len(args) == 1 and isinstance(args[0], Finding):
        return args[0]
    return Finding(f"warning.{caught.category.__name__}", str(message) or caught.category.__name__)


def _plain(value: Value) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value
