"""One view per selection: every candidate scored as a free body when the data hold one.

A free body (no spring to ground) is identified with a known virtual spring and scored by the
force it predicts from the measured motion (:mod:`bayesnsi.nsi.free_body`, docs/method.md §11);
a structure held by springs is scored on its displacements. The route is chosen per candidate
(``[nsi] virtual_stiffness = "auto"``: a rigid-body pole where the identification would fail), so
one selection could hold both, and their log-evidences, of different data (force residual against
displacement residual), were ranked as if comparable. Measured on a carriage in a position loop
(M 20 kg, Fv 30 N s/m, Coulomb 8 N, 1 µm position noise): the Coulomb and v|v| candidates came out
as free bodies (log Z -2438 and -3887, force), linear and cubic x³ did not (their first estimate
holds a stable pair at 0.5-0.6 Hz: the friction and the loop look like a spring) and were scored
on the displacement (+262 813 and +263 132), so cubic was selected with P = 1 while Coulomb
(Fc 7.99 N, M 20.1 kg, Fv 29.2 N s/m) validated best. When one candidate is a free body, the
others are identified again with its virtual spring (:func:`one_view`), and a candidate that
still is not a free body is named in a warning.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..nsi import is_free_body
from ..options import EvidenceOptions, ExecutionOptions, NSIOptions
from .batch import CandidateOutcome, run_candidates

__all__ = ["one_view"]


def one_view(
    signals, outcomes: Sequence[CandidateOutcome], nsi: NSIOptions | None, evidence: EvidenceOptions | None,
    execution: ExecutionOptions | None = None,
) -> tuple[tuple[CandidateOutcome, ...], tuple[str, ...]]:
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
    (tuple of CandidateOutcome, tuple of str)
        The outcomes (a rerun replaces a candidate's outcome when it identifies as a free body) and
        messages: which candidates were identified again, and which could not be.
    """
    nsi = nsi or NSIOptions()
    outcomes = tuple(outcomes)
    free = [o for o in outcomes if o.result is not None and is_free_body(o.result)]
    others = [i for i, o in enumerate(outcomes) if o.result is None or not is_free_body(o.result)]
    if nsi.virtual_stiffness != "auto" or not free or not others:
        return outcomes, ()
    stiffness = free[0].result.virtual_stiffness
    quiet = (execution or ExecutionOptions()).replace(progress=None)  # the messages say what was run again
    again = run_candidates(signals, [outcomes[i].candidate for i in others], nsi.replace(virtual_stiffness=stiffness),
                           evidence, execution=quiet)
    out = list(outcomes)
    moved = []
    for i, outcome in zip(others, again):
        if outcome.result is not None and is_free_body(outcome.result):
            out[i] = outcome
            moved.append(outcome.name)
    names = ", ".join(repr(o.name) for o in free)
    messages = []
    if moved:
        messages.append(
            f"the data hold a free body (a rigid-body pole in {names}): {', '.join(map(repr, moved))} "
            f"identified again with its virtual spring k = {stiffness:.4g}, so that every candidate is scored on "
            "the force it predicts from the measured motion (their first identification had no rigid-body pole)"
        )
    apart = [o.name for o in out if o.result is not None and not is_free_body(o.result)]
    if apart:
        messages.append(
            f"{', '.join(map(repr, apart))} could not be identified as a free body ({names} are): their evidence "
            "scores the displacement, the others' the force, and the two are not comparable"
        )
    return tuple(out), tuple(messages)
