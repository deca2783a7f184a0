"""bayesnsi: which nonlinearity is in the structure, where, and how sure we are.

Nonlinear subspace identification (NSI) of candidate nonlinear models from measured forces and
responses, with Bayesian model selection. The top-level namespace holds the numerical core
(numpy/scipy only); evidence (emcee, arviz), file I/O (pandas) and figures (matplotlib) live in
``bayesnsi.evidence``, ``bayesnsi.io`` and ``bayesnsi.plots`` and are imported on demand.

Example
-------
>>> from bayesnsi import NSIOptions, identify, simulate_case
>>> case = simulate_case("two-dof", seed=0)
>>> result = identify(case.signals, case.candidates[0], NSIOptions(block_rows=60, order=4))
>>> round(result.coefficients[0].value)
20
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._version import __version__
from .exceptions import BayesNSIError
from .options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions

if TYPE_CHECKING:
    from .diagnosis import Diagnosis, FinalModel, diagnose
    from .findings import Finding
    from .models import CandidateModel, Term, parse_expression
    from .nsi import NSIResult, affine_reconstruction, identify, reconstruct
    from .selection import Selection, select
    from .signals import Signals, differentiate
    from .simulate import simulate_case

# The numerical names are imported on first use (PEP 562), so that `import bayesnsi.cli` and
# `bayesnsi --help` do not pay for numpy and scipy.
_LAZY = {
    "Diagnosis": "diagnosis", "FinalModel": "diagnosis", "diagnose": "diagnosis", "Finding": "findings",
    "CandidateModel": "models", "Term": "models", "parse_expression": "models",
    "NSIResult": "nsi", "affine_reconstruction": "nsi", "identify": "nsi", "reconstruct": "nsi",
    "Selection": "selection", "select": "selection",
    "Signals": "signals", "differentiate": "signals",
    "simulate_case": "simulate",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'bayesnsi' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "BayesNSIError",
    "CandidateModel",
    "Term",
    "parse_expression",
    "Signals",
    "differentiate",
    "identify",
    "NSIOptions",
    "EvidenceOptions",
    "LoopOptions",
    "ExecutionOptions",
    "NSIResult",
    "reconstruct",
    "affine_reconstruction",
    "select",
    "Selection",
    "diagnose",
    "Diagnosis",
    "FinalModel",
    "Finding",
    "simulate_case",
    "__version__",
]
