"""Running many identifications: dispatch (serial, joblib, Dask), resumable batches, sweeps.

- :func:`run_candidates` / :func:`run_datasets`: identify every candidate (on every dataset),
  with per-candidate seeds, a result cache and progress callbacks.
- :func:`dispatch`: run tasks serially, on local worker processes (``jobs``) or on a Dask
  cluster (``scheduler``), yielding results as they finish.
- :func:`dictionary_candidates` / :func:`subset_candidates`: candidate databases made of
  every subset of a dictionary of terms.
"""

from .._dispatch import backend_name, connect, dispatch
from .batch import CandidateOutcome, candidate_task, run_candidates, run_datasets
from .sweep import (
    MAX_CANDIDATES,
    count_subsets,
    dictionary_candidates,
    subset_candidates,
)

__all__ = [
    "MAX_CANDIDATES",
    "CandidateOutcome",
    "backend_name",
    "candidate_task",
    "connect",
    "count_subsets",
    "dictionary_candidates",
    "dispatch",
    "run_candidates",
    "run_datasets",
    "subset_candidates",
]
