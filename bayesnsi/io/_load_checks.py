"""Checks of a config against its loaded data, made at load, before any candidate runs.

- **One channel mapped twice**: two mapped channels (force and a response, or two responses)
  holding the same samples up to a gain, e.g. the same column of a file named by two keys
  of ``[data] files``, or a file whose two columns are copies. A model cannot tell such
  channels apart; the run would identify nonsense. Refused with :class:`InputDataError`.
- **A spring for a free body on a grounded structure**: a fixed ``[nsi] virtual_stiffness``
  on a record whose linear model, identified without it, is stable with physical modes and no
  rigid-body pole (:func:`bayesnsi.nsi.grounded_modes`). Warned loudly
  (:class:`~bayesnsi.exceptions.FreeBodyWarning`, also in the report and results.json), naming
  the modes and what the spring would do.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from ..exceptions import FreeBodyWarning, InputDataError

__all__ = ["check_loaded"]

_SAME_RTOL = 1e-12
"""Two standardised channels closer than this (relative RMS) are the same channel."""


def check_loaded(config, signals) -> None:
    """Check ``signals`` against ``config`` before the expensive work (see the module notes).

    Parameters
    ----------
    config : ExperimentConfig
    signals : Signals
        Its estimation data.

    Raises
    ------
    InputDataError
        When two mapped channels hold the same samples up to a gain.
    """
    _check_distinct_channels(signals, config.path)
    stiffness = config.nsi.virtual_stiffness
    if stiffness != "auto" and float(stiffness) > 0:
        _warn_if_grounded(config, signals, float(stiffness))


def _check_distinct_channels(signals, where) -> None:
    names = [*signals.input_names, *signals.output_names]
    columns = np.column_stack([np.asarray(signals.force), np.asarray(signals.displacement)])
    standard = columns - columns.mean(axis=0)
    norms = np.linalg.norm(standard, axis=0)
    for i, j in itertools.combinations(range(columns.shape[1]), 2):
        if norms[i] == 0 or norms[j] == 0:
            continue
        a, b = standard[:, i] / norms[i], standard[:, j] / norms[j]
        if min(np.linalg.norm(a - b), np.linalg.norm(a + b)) <= _SAME_RTOL * np.sqrt(2):
            raise InputDataError(
                f"{where}: channels {names[i]!r} and {names[j]!r} hold the same samples (up to a gain): one "
                "channel is mapped twice; map each column of the data once ([data] inputs, outputs, files)"
            )


def _warn_if_grounded(config, signals, stiffness: float) -> None:
    from ..nsi import grounded_modes

    modes = grounded_modes(signals, config.nsi)
    if modes is None:
        return
    found = ", ".join(f"{m.frequency_hz:.3g} Hz" for m in modes[:6])
    warnings.warn(
        f"[nsi] virtual_stiffness = {stiffness:g} is meant for a free body, but this record's structure looks "
        f"grounded: identified without it, its linear part is stable with modes at {found} and no rigid-body pole. "
        f"Every candidate is identified with a spring of {stiffness:g} N/m added on DOF(s) "
        f"{tuple(signals.input_dofs)} and then removed from a structure that never had it, which moves the modes "
        'and the coefficients; drop virtual_stiffness, or use "auto" (a spring only where a rigid-body pole '
        "makes the identification fail)",
        FreeBodyWarning,
        stacklevel=3,
    )
