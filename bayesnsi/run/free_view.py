"""One view per selection: every candidate scored as a free body when the data hold one.

The policy is :mod:`bayesnsi.checks.free_view`; :func:`one_view` applies it to a batch of outcomes.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..checks.free_view import free_body_view, view_findings
from ..findings import Finding
from ..nsi import is_free_body
from ..options import EvidenceOptions, ExecutionOptions, NSIOptions
from .batch import CandidateOutcome, run_candidates

__all__ = ["one_view"]


def one_view(
    signals, outcomes: Sequence[CandidateOutcome], nsi: NSIOptions | None, evidence: EvidenceOptions | None,
    execution: ExecutionOptions | None = None,
) -> tuple[tuple[CandidateOutcome, ...], tuple[Finding, ...]]:
    """The outcomes with every candidate identified as a free body when one of them is.

    Parameters
    ----------
    signals : Signals
        Estimation data.
    outcomes : sequence of CandidateOutcome
        From :func:`bayesnsi.run.run_candidates`, in the candidates' order.
    nsi : NSIOptions or None
        The settings they were identified with; nothing changes unless ``virtual_stiffness`` is
        ``"auto"``.
    evidence : EvidenceOptions or None
        Evidence settings of the rerun.
    execution : ExecutionOptions, optional
        Backend and cache of the rerun (its progress callback is not called: the messages say
        which candidates ran again).

    Returns
    -------
    (tuple of CandidateOutcome, tuple of Finding)
        The outcomes (a rerun replaces a candidate's outcome when it identifies as a free body) and
        what the view did (:func:`bayesnsi.checks.free_view.view_findings`).
    """
    outcomes = tuple(outcomes)
    view = free_body_view(nsi or NSIOptions(), (o.result for o in outcomes))
    others = [i for i, o in enumerate(outcomes) if o.result is None or not is_free_body(o.result)]
    if view is None or not others:
        return outcomes, ()
    free = [o.name for o in outcomes if o.result is not None and is_free_body(o.result)]
    quiet = (execution or ExecutionOptions()).replace(progress=None)  # the findings say what was run again
    again = run_candidates(signals, [outcomes[i].candidate for i in others], view, evidence, execution=quiet)
    out = list(outcomes)
    moved = []
    for i, outcome in zip(others, again):
        if outcome.result is not None and is_free_body(outcome.result):
            out[i] = outcome
            moved.append(outcome.name)
    apart = [o.name for o in out if o.result is not None and not is_free_body(o.result)]
    return tuple(out), view_findings(free, moved, apart, float(view.virtual_stiffness))
