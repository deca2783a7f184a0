"""One view per record: when the data hold a free body, every model is scored as one.

A free body (no spring to ground) is identified with a known virtual spring and scored by the force
it predicts from the measured motion (:mod:`bayesnsi.nsi.free_body`, docs/method.md §11); a
structure held by springs is scored on its displacements. Whether a model is a free body is decided
per identification (``[nsi] virtual_stiffness = "auto"``: a rigid-body pole), so models of one record
could be scored on different data (force residual against displacement residual), and their
log-evidences compared as if comparable. On a carriage in a position loop (M 20 kg, Fv 30 N s/m,
Coulomb 8 N, 1 µm position noise) the Coulomb and v|v| candidates came out as free bodies (log Z
-2438 and -3887, force), linear and cubic did not (the friction and the loop look like a spring;
+262 813 and +263 132, displacement): cubic was selected with P = 1 while Coulomb validated best,
and the loop from the linear model gave sign(v1) a log Bayes factor of -265 251.

The policy, used by the selection (:func:`bayesnsi.run.one_view`) and by the loop
(:func:`bayesnsi.loop.free_view.free_body_start`): as soon as one model of the record identifies as a
free body, every model is identified with that model's virtual spring (:func:`free_body_view`); a
model that still is not a free body is named (:func:`view_findings`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from ..findings import Finding
from ..nsi import is_free_body
from ..options import NSIOptions

__all__ = ["free_body_view", "view_findings"]


def free_body_view(nsi: NSIOptions, models: Iterable) -> NSIOptions | None:
    """The identification settings of the free-body view, when the data call for it.

    Parameters
    ----------
    nsi : NSIOptions
        The settings the models were identified with; nothing changes unless
        ``virtual_stiffness`` is ``"auto"``.
    models : iterable of NSIResult or None
        Identified models of one record (None entries: not identified).

    Returns
    -------
    NSIOptions or None
        ``nsi`` with ``virtual_stiffness`` fixed to the first free body's spring; None when the
        view is fixed by the user or no model is a free body.
    """
    if nsi.virtual_stiffness != "auto":
        return None
    free = next((m for m in models if m is not None and is_free_body(m)), None)
    return None if free is None else nsi.replace(virtual_stiffness=free.virtual_stiffness)


def view_findings(free: Sequence[str], moved: Sequence[str], apart: Sequence[str],
                  stiffness: float) -> tuple[Finding, ...]:
    """What the one view did: who was identified again with the virtual spring, who could not be.

    Parameters
    ----------
    free : sequence of str
        Models identified as free bodies at first.
    moved : sequence of str
        Models identified again as free bodies with the virtual spring.
    apart : sequence of str
        Models that still are not free bodies.
    stiffness : float
        The virtual spring [N/m].

    Returns
    -------
    tuple of Finding
        ``free_body.view`` (a note) and ``free_body.apart`` (a warning: incomparable evidences).
    """
    names = ", ".join(repr(n) for n in free)
    out = []
    if moved:
        out.append(Finding(
            "free_body.view",
            f"the data hold a free body (a rigid-body pole in {names}): {', '.join(map(repr, moved))} "
            f"identified again with its virtual spring k = {stiffness:.4g}, so that every candidate is scored on "
            "the force it predicts from the measured motion (their first identification had no rigid-body pole)",
            "", "note", {"virtual_stiffness": float(stiffness), "moved": tuple(moved)}))
    if apart:
        out.append(Finding(
            "free_body.apart",
            f"{', '.join(map(repr, apart))} could not be identified as a free body ({names} are): their evidence "
            "scores the displacement, the others' the force, and the two are not comparable",
            "", "warning", {"virtual_stiffness": float(stiffness), "apart": tuple(apart)}))
    return tuple(out)
