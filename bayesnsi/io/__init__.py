"""File input/output: the only layer that touches files.

- :mod:`~bayesnsi.io.config`: TOML experiment configuration -> :class:`ExperimentConfig`.
- :mod:`~bayesnsi.io.measurements`: measurements (CSV, MATLAB .mat, HDF5, UFF58) ->
  :class:`~bayesnsi.signals.Signals`; Signals -> CSV.
- :mod:`~bayesnsi.io.results`: atomic writes, JSON conversion, versions, output folders.
- :mod:`~bayesnsi.io.schema`, :mod:`~bayesnsi.io.loop_record`: results.json records from the library's
  typed results (:class:`~bayesnsi.selection.Selection`, :class:`~bayesnsi.diagnosis.Diagnosis`).
"""

from ._formats import UFF_DIRECTIONS, uff_channel_key
from .config import (
    DataSpec,
    ExperimentConfig,
    IntegrationSpec,
    ValidationSegment,
    dump_config,
    load_config,
)
from .loop_record import diagnosis_payload, step_record
from .measurements import (
    FORMATS,
    FS_TOLERANCE,
    TIME_TOLERANCE,
    CSVColumns,
    MeasurementColumns,
    file_format,
    load_signals,
    load_validation,
    read_columns,
    read_csv_columns,
    read_csv_signals,
    read_signals,
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
from .schema import candidate_record, identification_payload, intervals_record, selection_payload, term_record

__all__ = [
    "DataSpec",
    "IntegrationSpec",
    "ValidationSegment",
    "ExperimentConfig",
    "load_config",
    "dump_config",
    "CSVColumns",
    "read_csv_columns",
    "read_csv_signals",
    "read_signals",
    "read_columns",
    "MeasurementColumns",
    "file_format",
    "uff_channel_key",
    "UFF_DIRECTIONS",
    "FORMATS",
    "FS_TOLERANCE",
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
    "candidate_record",
    "diagnosis_payload",
    "identification_payload",
    "intervals_record",
    "step_record",
    "selection_payload",
    "term_record",
]
