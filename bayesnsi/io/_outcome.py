"""Explicit conversions of a candidate's outcome to plain data and back (the cache's schema).

Each result class is described field by field (:class:`Struct`): every field has a kind that
encodes it with :func:`~bayesnsi.io._store.encode_value` and checks what is read back (type,
array dtype and number of dimensions, allowed values). Terms are stored as their expression text
and location and rebuilt through the expression parser (:class:`~bayesnsi.models.Term`), never
evaluated. A class that gains a field the schema does not list is refused when stored, so a
result is never cached incompletely.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..checks.validation import Whiteness
from ..evidence import (
    BlockStatistics,
    BridgeEstimate,
    ConvergenceReport,
    EvidenceResult,
    PosteriorSamples,
    QuadratureEvidence,
    SamplerRecord,
)
from ..exceptions import BayesNSIError
from ..findings import Finding, finding_from_dict
from ..models import CandidateModel, Term
from ..nsi import CoefficientEstimate, IdentificationFit, Mode, NSIResult, StateSpaceModel
from ..options import NSIOptions
from ..run.batch import FAILED_STAGES, CandidateOutcome
from ..uncertainty import Intervals, ParameterInterval
from ._plain_kinds import (
    BOOL,
    COMPLEX,
    FLOAT,
    INT,
    OPTIONAL_FLOAT,
    OPTIONAL_INT,
    OPTIONAL_STR,
    STR,
    Array,
    Choice,
    Frame,
    Named,
    Sequence,
    Struct,
    Typed,
)
from ._store import EntryError

__all__ = ["outcome_from_plain", "outcome_to_plain", "schema_fields"]

_MAX_EXPRESSION = 2000  # characters of a stored term expression


class _Finding:
    """A :class:`Finding`: its JSON record (:meth:`Finding.to_dict`), checked when read."""

    def encode(self, value: Finding, arrays: dict) -> Any:
        if not isinstance(value, Finding):
            raise TypeError(f"expected Finding, got {type(value).__name__}")
        return value.to_dict()

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Finding:
        if not (isinstance(plain, dict) and {"kind", "message"} <= set(plain) <= set(_FINDING_KEYS)
                and all(isinstance(plain.get(k, ""), str) for k in ("kind", "message", "subject", "severity"))
                and isinstance(plain.get("values", {}), dict)):
            raise EntryError(f"{where}: a finding needs a kind, a message and at most {_FINDING_KEYS}")
        try:
            return finding_from_dict(plain)
        except (TypeError, ValueError) as err:
            raise EntryError(f"{where}: invalid finding ({err})") from None


_FINDING_KEYS = ("kind", "subject", "severity", "values", "message")


class _OptionsKind:
    """An options dataclass (:mod:`bayesnsi.options`): its plain record, validated again when read."""

    def __init__(self, cls: type[Any]):
        self.cls = cls

    def encode(self, value: Any, arrays: dict) -> Any:
        if not isinstance(value, self.cls):
            raise TypeError(f"expected {self.cls.__name__}, got {type(value).__name__}")
        return value.to_dict()

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Any:
        if not isinstance(plain, dict):
            raise EntryError(f"{where}: expected a table of {self.cls.__name__}")
        try:
            return self.cls.from_mapping(plain)
        except BayesNSIError as err:
            raise EntryError(f"{where}: invalid {self.cls.__name__} ({err})") from None


class _Term:
    """A :class:`Term`: expression text and location, parsed again when read."""

    def encode(self, value: Term, arrays: dict) -> Any:
        return {"expr": value.expr.text, "at": list(value.at)}

    def decode(self, plain: Any, arrays: Mapping, where: str) -> Term:
        if not (isinstance(plain, dict) and set(plain) == {"expr", "at"} and isinstance(plain["expr"], str)
                and isinstance(plain["at"], list) and all(type(a) is int for a in plain["at"])):
            raise EntryError(f"{where}: a term needs an expression text and a list of DOFs")
        if len(plain["expr"]) > _MAX_EXPRESSION:
            raise EntryError(f"{where}: expression text longer than {_MAX_EXPRESSION} characters")
        try:
            return Term(plain["expr"], tuple(plain["at"]))
        except (BayesNSIError, RecursionError) as err:
            raise EntryError(f"{where}: invalid term ({err})") from None


def _check_nsi(result: NSIResult) -> str | None:
    A, B, C, D = (result.model.A, result.model.B, result.model.C, result.model.D)
    n, m, n_out = A.shape[0], B.shape[1], C.shape[0]
    if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n or D.shape != (n_out, m):
        return f"state-space shapes A {A.shape}, B {B.shape}, C {C.shape}, D {D.shape}"
    if len(result.coefficients) != result.candidate.n_terms or m != len(result.input_dofs) + result.candidate.n_terms:
        return f"{len(result.coefficients)} coefficients and {m} inputs for {result.candidate.n_terms} terms"
    if n_out != len(result.output_dofs) or len(result.band_hz) != 2:
        return f"{n_out} outputs for output DOFs {result.output_dofs}, band {result.band_hz}"
    if result.order != n or result.block_rows < 1:
        return f"order {result.order} for a {n}x{n} A (block rows {result.block_rows})"
    if not all(np.all(np.isfinite(M)) for M in (A, B, C, D)) or not np.isfinite(result.model.dt):
        return "a state-space matrix holding NaN or Inf"
    return None


def _check_posterior(posterior: PosteriorSamples) -> str | None:
    shape = posterior.samples.shape
    n_params = len(posterior.param_names)
    if (shape[2] != n_params or posterior.log_posterior.shape != shape[:2]
            or posterior.acceptance_fraction.shape != shape[:1] or posterior.autocorr_time.shape != (n_params,)
            or posterior.mode.shape != (n_params,) or posterior.mode_covariance.shape != (n_params, n_params)
            or len(posterior.coefficient_names) > n_params):
        return f"samples {shape} for {n_params} parameters"
    return None


def _check_evidence(evidence: EvidenceResult) -> str | None:
    q = len(evidence.coefficient_names)
    if evidence.ci95.shape != (q, 2) or evidence.posterior.coefficient_names != evidence.coefficient_names:
        return f"ci95 {evidence.ci95.shape} for {q} coefficients"
    return None


def _check_outcome(outcome: CandidateOutcome) -> str | None:
    if outcome.result is not None and outcome.result.candidate != outcome.candidate:
        return "the NSI result is for another candidate"
    if outcome.evidences is not None and (outcome.result is None or not outcome.evidences):
        return "evidences without an NSI result"
    if (outcome.error is None) != (outcome.failed_stage is None):
        return "an error without a failed stage, or the reverse"
    if outcome.result is None and outcome.error is None:
        return "neither a result nor an error"
    return None


FLOATS, INTS, STRS = Sequence(FLOAT), Sequence(INT), Sequence(STR)
FINDINGS = Sequence(_Finding())
TERM = _Term()

CANDIDATE = Struct(CandidateModel, {
    "name": STR, "terms": Sequence(TERM), "prior": FLOAT, "coefficient_prior_scales": Sequence(OPTIONAL_FLOAT),
})

NSI_RESULT = Struct(NSIResult, {
    "candidate": CANDIDATE,
    "model": Struct(StateSpaceModel, {
        "A": Array("float64", 2), "B": Array("float64", 2), "C": Array("float64", 2), "D": Array("float64", 2),
        "dt": FLOAT,
    }),
    "singular_values": Array("float64", 1),
    "order": INT,
    "block_rows": INT,
    "input_dofs": INTS,
    "output_dofs": INTS,
    "band_hz": FLOATS,
    "modes": Sequence(Struct(Mode, {"frequency_hz": FLOAT, "damping_ratio": FLOAT, "pole": COMPLEX})),
    "spurious_poles": Array("complex128", 1),
    "coefficients": Sequence(Struct(CoefficientEstimate, {
        "term": TERM, "value": FLOAT, "imag_ratio": FLOAT, "band_hz": FLOATS, "spread": FLOAT,
        "excluded_fraction": FLOAT,
    })),
    "options": _OptionsKind(NSIOptions),
    "fit": Struct(IdentificationFit, {
        "n_samples": INT, "fs": FLOAT, "reflected_poles_hz": FLOATS, "virtual_mode_mirrored_hz": FLOATS,
        "fit_band_hz": Typed(tuple, none=True), "requested_block_rows": OPTIONAL_INT,
        "period": INT, "n_periods": INT, "n_realisations": INT,
        "n_lines": INT, "n_band_lines": INT, "stable_modes_hz": FLOATS,
        "line_misfit": OPTIONAL_FLOAT, "band_misfit": OPTIONAL_FLOAT,
        "unexcited_ratio": Typed(tuple, none=True),
    }),
    "rigid_body_poles": Array("complex128", 1),
}, none=True, check=_check_nsi)

EVIDENCE_RESULT = Struct(EvidenceResult, {
    "log_evidence": FLOAT,
    "log_evidence_se": FLOAT,
    "laplace_log_evidence": FLOAT,
    "closed_form_log_evidence": OPTIONAL_FLOAT,
    "plain_log_likelihood": FLOAT,
    "likelihood": STR,
    "coefficient_names": STRS,
    "posterior": Struct(PosteriorSamples, {
        "samples": Array("float64", 3),
        "log_posterior": Array("float64", 2),
        "param_names": STRS,
        "coefficient_names": STRS,
        "channel_names": STRS,
        "likelihood": STR,
        "ar_order": INT,
        "acceptance_fraction": Array("float64", 1),
        "autocorr_time": Array("float64", 1),
        "autocorr_reliable": BOOL,
        "mode": Array("float64", 1),
        "mode_covariance": Array("float64", 2),
        "settings": Typed(dict),
        "sampler": Struct(SamplerRecord, {
            "name": STR, "version": STR, "moves": STRS, "weights": FLOATS, "n_walkers": INT, "n_steps": INT,
            "n_burn": INT, "parameters": STR,
        }, none=True),
    }, check=_check_posterior),
    "summary": Frame(),
    "convergence": Struct(ConvergenceReport, {
        "rhat_max": FLOAT, "ess_bulk_min": FLOAT, "ess_tail_min": FLOAT, "worst_rhat": STR, "worst_ess": STR,
        "rhat_threshold": FLOAT, "ess_threshold": FLOAT, "n_chains": INT, "n_draws": INT,
    }),
    "rhat_max": FLOAT,
    "ess_min": FLOAT,
    "ci95": Array("float64", 2),
    "bridge": Struct(BridgeEstimate, {
        "log_evidence": FLOAT, "se": FLOAT, "n_posterior": INT, "n_proposal": INT, "n_posterior_eff": FLOAT,
        "n_iterations": INT, "converged": BOOL, "proposal": STR,
    }),
    "settings": Typed(dict),
    "priors_text": STR,
    "warnings": STRS,
    "quadrature": Struct(QuadratureEvidence, {"log_evidence": FLOAT, "error": FLOAT, "n_nodes": INT, "n_passes": INT},
                          none=True),
    "blocks": Struct(BlockStatistics, {
        "bounds": Array("int64", 2), "lagged": Array("float64", 5), "head": Array("float64", 4),
        "tail": Array("float64", 4), "measured_std": Array("float64", 2), "center": Array("float64", 1),
        "names": STRS,
    }, none=True),
}, check=_check_evidence)

_PARAMETER_INTERVALS = Sequence(Struct(ParameterInterval, {
    "name": STR, "estimate": FLOAT, "sd": FLOAT, "posterior_sd": FLOAT, "segment_sd": FLOAT, "ci50": FLOATS,
    "ci95": FLOATS, "posterior_mean": FLOAT, "bias": FLOAT,
}))

INTERVALS = Struct(Intervals, {
    "method": STR, "coefficients": _PARAMETER_INTERVALS, "frequencies": _PARAMETER_INTERVALS,
    "damping_ratios": _PARAMETER_INTERVALS, "n_segments": INT, "segment_samples": INT, "findings": FINDINGS,
}, none=True, fixed={"widening": 1.0})  # widened for inadequacy by select after the cache (uncertainty.widening)

OUTCOME = Struct(CandidateOutcome, {
    "candidate": CANDIDATE,
    "result": NSI_RESULT,
    "evidences": Named(EVIDENCE_RESULT),
    "nrmse": OPTIONAL_FLOAT,
    "nrmse_per_channel": FLOATS,
    "error": OPTIONAL_STR,
    "failed_stage": Choice(FAILED_STAGES),
    "traceback": OPTIONAL_STR,
    "findings": FINDINGS,
    "intervals": INTERVALS,
    "whiteness": Struct(Whiteness, {
        "residual": STR, "max_lag": INT, "statistic": FLOATS, "p_value": FLOATS, "fraction_outside": FLOATS,
    }, none=True),
    "seconds": FLOAT,
}, fixed={"cached": True}, check=_check_outcome)


def outcome_to_plain(outcome: CandidateOutcome) -> tuple[dict, dict[str, np.ndarray]]:
    """Plain data of a candidate's outcome: JSON values and the arrays they name.

    Parameters
    ----------
    outcome : CandidateOutcome

    Returns
    -------
    document : dict
        JSON values (NaN and ±Infinity included as such).
    arrays : dict of str to ndarray
        Arrays named by ``document`` (dtypes float64, complex128, int64).

    Raises
    ------
    TypeError
        If the outcome holds a value the schema does not describe (e.g. a new field).
    """
    arrays: dict[str, np.ndarray] = {}
    return OUTCOME.encode(outcome, arrays), arrays


def outcome_from_plain(document: Any, arrays: Mapping[str, np.ndarray]) -> CandidateOutcome:
    """Rebuild a :class:`CandidateOutcome` (with ``cached = True``) from :func:`outcome_to_plain`.

    Parameters
    ----------
    document : object
        JSON values as read.
    arrays : mapping of str to ndarray
        The arrays of the entry.

    Returns
    -------
    CandidateOutcome

    Raises
    ------
    EntryError
        If anything does not match the schema (a missing or extra field, a wrong type, dtype or
        number of dimensions, an invalid term or candidate).
    """
    return OUTCOME.decode(document, arrays, "outcome")


def schema_fields() -> dict[str, set[str]]:
    """Field names the schema stores (or sets) per result class, for checks against the classes.

    Returns
    -------
    dict of str to set of str
        Class name -> field names.
    """
    found: dict[str, set[str]] = {}
    pending = [OUTCOME]
    while pending:
        kind = pending.pop()
        if isinstance(kind, (Sequence, Named)):
            pending.append(kind.item)
        elif isinstance(kind, Struct):
            found[kind.cls.__name__] = set(kind.fields) | set(kind.fixed)
            pending.extend(kind.fields.values())
    return found
