"""Screening effects of a free body in the force (inverse-model, IDIM) view (docs/method.md §7, §11).

The frequency-domain screen (:func:`bayesnsi.loop.screen_effects`) regresses the displacement
spectra on the extended input up to 1.6 × the highest mode. A free body has no mode, and its
displacement at low frequencies is the integral of everything (the rigid-body mode), so that
screen sees a handful of bins and ranks friction among look-alikes (EMPS: sign(v) 8th of 10
on the EMPS axis). The field screens a positioning axis in the force view instead: on the
low-pass filtered record (:func:`bayesnsi.nsi.inverse.filtered_kinematics`), the measured force is
regressed on ``[a, v, x, 1]`` and the current model's basis functions, and each effect is scored by
the Gaussian log-likelihood ratio of adding its basis function ``n_e(x, v)``::

    score_e = N log(RSS_without / RSS_with)

with N the samples kept (one every ``fs/cutoff``, so that the filter does not multiply
correlated samples). As for the frequency-domain screen, the score only orders the effects; the
evidence decides.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..exceptions import NotIdentifiableError
from ..nsi.inverse import edge_samples, filtered_kinematics, parallel_filter

if TYPE_CHECKING:
    from ..models.dictionary import Effect

__all__ = ["screen_effects_force"]


def screen_effects_force(signals, candidate, effects, *, cutoff_hz: float | None = None) -> list[tuple[Effect, float]]:
    """Rank effects by how much of a one-DOF free body's force residual they explain (module notes).

    Parameters
    ----------
    signals : Signals
        Estimation data: one force and one displacement at the same DOF.
    candidate : CandidateModel
        The current model; its terms are regressors.
    effects : list of Effect
        Effects to rank (those already in ``candidate`` are skipped).
    cutoff_hz : float, optional
        Low-pass cutoff (default fs/20).

    Returns
    -------
    list of (Effect, float)
        Best first; ``-inf`` for an effect whose basis cannot be evaluated or is constant.

    Raises
    ------
    NotIdentifiableError
        When the data are not one force and one displacement at the same DOF.
    """
    if tuple(signals.input_dofs) != tuple(signals.output_dofs) or len(signals.input_dofs) != 1:
        raise NotIdentifiableError("the force-view screen needs one force and one displacement at the same DOF")
    dof = signals.input_dofs[0]
    x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
    step = max(1, int(signals.fs / cutoff))  # about one sample per correlation time of the filter
    trim = edge_samples(signals.fs, cutoff)
    keep = slice(trim, len(f) - trim, step)
    rows_x, rows_v = np.tile(x, (dof, 1)), np.tile(v, (dof, 1))  # row dof-1 is the measured DOF

    def basis(term):
        with np.errstate(all="ignore"):
            column = term.evaluate(rows_x, rows_v)
        if not np.all(np.isfinite(column)):
            return column[keep]
        return parallel_filter(column, signals.fs, cutoff)[keep]  # filtered as the force was

    present = {t.name for t in candidate.terms}
    columns = [a[keep], v[keep], x[keep], np.ones_like(x[keep])] + [basis(t) for t in candidate.terms]
    q, _ = np.linalg.qr(np.column_stack(columns))
    target = f[keep]
    residual = target - q @ (q.T @ target)
    rss = float(residual @ residual)
    n = len(target)
    scored = []
    for effect in effects:
        if effect.term.name in present:
            continue
        value = basis(effect.term)
        if not np.all(np.isfinite(value)) or not np.std(value) > 0:
            scored.append((effect, -np.inf))
            continue
        new = value - q @ (q.T @ value)
        power = float(new @ new)
        explained = float(new @ residual) ** 2 / power if power > 0 else 0.0
        fraction = min(max(explained / rss, 0.0), 1.0 - 1e-12) if rss > 0 else 0.0
        scored.append((effect, -n * float(np.log1p(-fraction))))
    order = sorted(range(len(scored)), key=lambda k: -scored[k][1])
    return [scored[k] for k in order]
