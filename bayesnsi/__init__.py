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

from ._version import __version__
from .exceptions import BayesNSIError
from .models import CandidateModel, Term, parse_expression
from .nsi import NSIResult, affine_reconstruction, identify, reconstruct
from .options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions
from .selection import Selection, select
from .signals import Signals, differentiate
from .simulate import simulate_case

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
    "simulate_case",
    "__version__",
]
