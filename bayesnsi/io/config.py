"""Experiment configuration: TOML file -> frozen :class:`ExperimentConfig` (docs/method.md §9).

Layout (everything but ``[data]`` inputs/outputs and ``[[candidates]]`` has a default)::

    seed = 0                                  # optional; or in [evidence]

    [data]
    file = "two_dof.csv"                      # relative to this config file's folder; .csv (or any
                                              # other text), .mat (v5 or v7.3), .h5/.hdf5, .uff/.unv
    fs = 100.0                                # Hz; omit to derive it from the time column "t"
    inputs = { f2 = 2 }                       # force column -> DOF (numbered from 1)
    outputs = { x1 = 1, x2 = 2 }              # displacement column -> DOF
    velocities = { v1 = 1, v2 = 2 }           # optional, same DOFs as outputs
    accelerations = { a1 = 1 }                # optional; stored only, unless integrate is given
    estimation = [0, 800]                     # optional sample window [start, stop) of the file
    remove_mean = false                       # optional
    decimate = 1                              # optional integer factor (anti-aliased)
    scale = { f2 = 35.15 }                    # optional gain per column (force = drive gain × current)

    # accelerations only: instead of outputs/velocities
    # accelerations = { a1 = 1, a2 = 2 }
    # integrate = { band_hz = [1.0, 40.0] }   # + method, taper, filter_inputs, ... (DataSpec)
    #   noise_std = 0.002                     # declared accelerometer noise (else estimated before integrating)
    #   trim_edges = false                    # keep the 2/(taper f_lo) s at each end (default: dropped)
    # velocity sensors only (a laser vibrometer): instead of outputs
    # velocities = { v1 = 1, v2 = 2 }
    # integrate = { band_hz = [1.0, 40.0] }   # the same keys; displacements integrated once

    [nsi]                                     # all optional
    block_rows = 40
    order = "auto"                            # or an integer
    band_hz = [1.0, 10.0]                     # "band" is accepted as an alias
    velocity_method = "fourth"                # "central", "fourth", "sixth"
    bd_method = "robust"                      # or "output-error"
    max_order = 40
    zero_feedthrough = true

    [[candidates]]
    name = "quadratic damping"
    prior = 1.0                               # optional, unnormalised
    terms = [{ expr = "v1*abs(v1)", at = 1, prior_scale = 50.0 }]   # at = [j, k]: element j-k

    [[validation]]                            # optional, never used for estimation
    name = "tail"
    start = 800
    stop = 1000                               # or: file = "other.csv" (same columns)

    [evidence]                                # optional, numbers/strings/bools (and lists of them)
    [meta]                                    # optional, free-form notes (e.g. the true values)

Every mistake raises :class:`~bayesnsi.exceptions.ConfigError` naming the file, the section and
key, what was expected, what was found and what to do. Nothing in the file is evaluated: the
TOML is parsed by :mod:`tomllib` and expressions by :func:`bayesnsi.models.parse_expression`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .._text import check_path_text
from ..exceptions import ConfigError
from ..options import EvidenceOptions, LoopOptions, NSIOptions
from . import _toml
from ._config_fields import MISSING, Where, build_options, check_keys, read_toml
from ._config_sections import (
    MAX_CONFIG_CANDIDATES,
    TOO_MANY,
    parse_candidates,
    parse_data,
    parse_evidence,
    parse_nsi,
)
from ._config_validation import parse_validation
from ._specs import DataSpec, ExperimentConfig, IntegrationSpec, ValidationSegment

__all__ = [
    "DataSpec",
    "IntegrationSpec",
    "ValidationSegment",
    "ExperimentConfig",
    "MAX_CONFIG_CANDIDATES",
    "load_config",
    "dump_config",
]

_TOP_KEYS = (
    "seed", "data", NSIOptions.SECTION, "candidates", "validation", EvidenceOptions.SECTION, LoopOptions.SECTION,
    "meta",
)


def load_config(path: str | os.PathLike, check_files: bool = True) -> ExperimentConfig:
    """Read and validate an experiment configuration (TOML, docs/method.md §9).

    Parameters
    ----------
    path : str or path-like
        The TOML file.
    check_files : bool
        Check that the data and validation files exist (their contents are read later, by
        :func:`bayesnsi.io.load_signals`).

    Returns
    -------
    ExperimentConfig

    Raises
    ------
    ConfigError
        On any mistake: unreadable TOML, unknown keys, wrong types, missing data mapping,
        bad expressions, terms on unmeasured DOFs, two terms of a candidate with proportional
        forces, names holding control characters, ``fs`` outside
        [:data:`~bayesnsi.signals.MIN_FS`, :data:`~bayesnsi.signals.MAX_FS`], overlapping
        validation segments, missing files; also a file over 8 MiB, tables nested deeper than 32
        levels or more than :data:`MAX_CONFIG_CANDIDATES` candidates.
    """
    check_path_text(path, "config file")
    try:
        path = Path(path).expanduser().resolve()
    except RuntimeError as exc:  # "~user" that names no user
        raise ConfigError(f"config path {str(path)!r}: {exc}; write the path without '~'") from exc
    if not path.is_file():
        raise ConfigError(f"config file {path} not found; check the path (relative paths start at the working folder)")
    raw = read_toml(path, {"candidates": (MAX_CONFIG_CANDIDATES, TOO_MANY)})
    top = Where(path, "top level")
    check_keys(raw, _TOP_KEYS, top)
    data = parse_data(raw.get("data", MISSING), Where(path, "[data]"), check_files)
    nsi = parse_nsi(raw.get(NSIOptions.SECTION, {}), Where(path, f"[{NSIOptions.SECTION}]"), data)
    candidates = parse_candidates(raw.get("candidates", MISSING), path, data)
    validation = parse_validation(raw.get("validation", []), path, data, check_files)
    evidence, seed = parse_evidence(raw, path)
    loop = build_options(LoopOptions, raw.get(LoopOptions.SECTION, {}), Where(path, f"[{LoopOptions.SECTION}]"))
    meta = raw.get("meta", {})
    if not isinstance(meta, dict):
        raise top.error("meta", "a table [meta]", meta, "write notes as [meta] key = value")
    return ExperimentConfig(
        path=path, data=data, nsi=nsi, candidates=candidates, validation=validation,
        evidence=evidence, loop=loop, seed=seed, raw=raw, meta=meta,
    )


def dump_config(config: Mapping[str, Any]) -> str:
    """Write a configuration dict as TOML text (the subset :func:`load_config` reads).

    Parameters
    ----------
    config : mapping
        Plain values: str, bool, int, float, path-like, lists/tuples, and mappings. At the top
        level a mapping becomes a ``[table]`` and a non-empty list of mappings an array of
        tables ``[[name]]``; deeper mappings become inline tables, and lists of mappings
        inside a table are written one inline table per line.

    Returns
    -------
    str
        TOML text with ``tomllib.loads(dump_config(d)) == d`` for such dicts (tuples and paths
        come back as lists and strings; NaN never compares equal).

    Raises
    ------
    ConfigError
        For values TOML cannot hold (None, other objects), naming the key.

    Examples
    --------
    >>> print(dump_config({"seed": 1, "nsi": {"order": "auto"}}), end="")
    seed = 1
    <BLANKLINE>
    [nsi]
    order = "auto"
    """
    return _toml.dumps(config)
