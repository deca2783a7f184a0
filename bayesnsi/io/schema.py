"""results.json records (SPEC section 9): plain dicts built from result objects.

Field names listed in SPEC 9 are stable; further fields are additions.
"""

from __future__ import annotations

from typing import Any

from ..models import CandidateModel, Term

__all__ = ["term_record", "candidate_record", "failed_candidate_record"]


def term_record(term: Term) -> dict[str, Any]:
    """``{expr, at}`` of a term, ``at`` an int or a pair as in the config."""
    return {"expr": term.expr.text, "at": term.at_value}


def candidate_record(result, reconstruction=None, closed_loop=None) -> dict[str, Any]:
    """Record of one identified candidate.

    Parameters
    ----------
    result : NSIResult
    reconstruction : Reconstruction, optional
        Open-loop reconstruction of the estimation data (gives ``nrmse``).
    closed_loop : Reconstruction, optional
        Closed-loop simulation of the estimation data (gives ``nrmse_closed_loop``).
    """
    record: dict[str, Any] = {
        "name": result.candidate.name,
        "status": "ok",
        "prior": result.candidate.prior,
        "terms": [term_record(t) for t in result.terms],
        "coefficients": [
            {
                **term_record(c.term),
                "value": c.value,
                "imag_ratio": c.imag_ratio,
                "spread": c.spread,
                "ci95": None,
            }
            for c in result.coefficients
        ],
        "modes": [{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio} for m in result.modes],
        "spurious_poles": [{"real": p.real, "imag": p.imag} for p in result.spurious_poles],
        "order": result.order,
        "block_rows": result.block_rows,
        "band_hz": list(result.band_hz),
        "singular_values": [float(s) for s in result.singular_values[: 2 * result.order + 10]],
    }
    if reconstruction is not None:
        record["nrmse"] = reconstruction.nrmse
        record["nrmse_per_channel"] = list(reconstruction.nrmse_per_channel)
    if closed_loop is not None:
        record["nrmse_closed_loop"] = closed_loop.nrmse
    return record


def failed_candidate_record(candidate: CandidateModel, error: BaseException) -> dict[str, Any]:
    """Record of a candidate whose identification failed, with the reason."""
    return {
        "name": candidate.name,
        "status": "failed",
        "error": f"{type(error).__name__}: {error}",
        "prior": candidate.prior,
        "terms": [term_record(t) for t in candidate.terms],
        "coefficients": [],
        "modes": [],
        "nrmse": None,
    }
