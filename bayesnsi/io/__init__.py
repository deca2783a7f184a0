"""File input/output: the only layer that touches files.

- :mod:`~bayesnsi.io.config`: TOML experiment configuration -> :class:`ExperimentConfig`.
- :mod:`~bayesnsi.io.measurements`: CSV measurements -> :class:`~bayesnsi.signals.Signals`.
- :mod:`~bayesnsi.io.results`: atomic writes, JSON conversion, versions, output folders.
"""

from .config import (
    BD_METHODS,
    VELOCITY_METHODS,
    DataSpec,
    ExperimentConfig,
    NSISettings,
    ValidationSegment,
    dump_config,
    load_config,
)
from .measurements import (
    TIME_TOLERANCE,
    CSVColumns,
    load_signals,
    load_validation,
    read_csv_columns,
    read_csv_signals,
    write_signals_csv,
)
from .results import (
    RESULTS_FILENAME,
    atomic_open,
    atomic_write_json,
    atomic_write_text,
    prepare_output_dir,
    to_jsonable,
    versions,
)

__all__ = [
    "DataSpec",
    "NSISettings",
    "ValidationSegment",
    "ExperimentConfig",
    "load_config",
    "dump_config",
    "VELOCITY_METHODS",
    "BD_METHODS",
    "CSVColumns",
    "read_csv_columns",
    "read_csv_signals",
    "load_signals",
    "load_validation",
    "write_signals_csv",
    "TIME_TOLERANCE",
    "RESULTS_FILENAME",
    "atomic_open",
    "atomic_write_text",
    "atomic_write_json",
    "to_jsonable",
    "versions",
    "prepare_output_dir",
]
