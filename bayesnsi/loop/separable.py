"""Whether the data can separate a proposed effect from the effects the loop already added.

docs/method.md §7 (guard "separable"). A proposed term is regressed, together with an effect the
loop added before, on the regressors of the linear part (displacement, velocity and acceleration
of every measured DOF and a constant) and the model's other terms; what is left of each column is
its part that the linear part and the rest cannot produce. The squared partial correlation of the
two left-over columns,

    rho2 = (r_new · r_k)^2 / (|r_new|^2 |r_k|^2),

is the share of the new column's own variation that the accepted effect already explains, and
``1 / (1 - rho2)`` is the factor by which adding the new term inflates the variance of the
accepted coefficient (the variance inflation factor of that pair). Beyond ``rho2 = 0.5`` the
accepted effect explains more of the new column than is left for the new term alone: the data
can only share a force between the two, and any model-form error moves both coefficients and the
linear part (on the EMPS axis v|v| after sign(v), rho2 = 0.68, moved Fv by +43 %).

A free body (one force, one displacement at the same DOF) is identified in the force view, so its
columns are taken there: low-pass filtered kinematics, nonlinear columns filtered once more
(:func:`bayesnsi.nsi.inverse.parallel_filter`), one sample per correlation time of the filter.
"""

from __future__ import annotations

import numpy as np

from ..nsi.inverse import edge_samples, filtered_kinematics, parallel_filter

__all__ = ["shared_fraction"]


def _columns(signals, terms, free_body: bool) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Regressors of the linear part and one column per term, in the view the loop identifies in."""
    n = signals.n_samples
    if free_body and len(signals.output_dofs) == 1 and tuple(signals.input_dofs) == tuple(signals.output_dofs):
        x, v, a, _, cutoff = filtered_kinematics(signals)
        trim = edge_samples(signals.fs, cutoff)
        keep = slice(trim, n - trim, max(1, int(signals.fs / cutoff)))
        dof = signals.output_dofs[0] - 1
        rows_x, rows_v = {dof: x}, {dof: v}

        def column(term):
            with np.errstate(all="ignore"):
                value = np.broadcast_to(term.evaluate(rows_x, rows_v), (n,)).astype(float)
            return parallel_filter(value, signals.fs, cutoff)[keep] if np.all(np.isfinite(value)) else value[keep]

        return [a[keep], v[keep], x[keep], np.ones(len(x[keep]))], [column(t) for t in terms]
    dofs = list(signals.output_dofs)
    xs, vs = signals.state_rows(dofs, dofs)
    linear = list(xs.values()) + list(vs.values())
    linear += [np.gradient(value, 1.0 / signals.fs) for value in vs.values()] + [np.ones(n)]
    with np.errstate(all="ignore"):
        columns = [np.broadcast_to(t.evaluate(xs, vs), (n,)).astype(float) for t in terms]
    return linear, columns


def _left_over(column: np.ndarray, others: list[np.ndarray]) -> np.ndarray:
    q, _ = np.linalg.qr(np.column_stack(others))
    return column - q @ (q.T @ column)


def shared_fraction(signals, terms, new, accepted, free_body: bool = False) -> tuple[str, float]:
    """The accepted effect that shares most of ``new``'s column, and that share (module notes).

    Parameters
    ----------
    signals : Signals
        The estimation data.
    terms : sequence of Term
        The current model's terms (declared and added).
    new : Term
        The proposed term.
    accepted : sequence of Term
        The terms of ``terms`` the loop added (the ones checked against).
    free_body : bool
        Take the columns in the force view (module notes; one force and one displacement at the same
        DOF, the state view otherwise).

    Returns
    -------
    (str, float)
        Name of that accepted term and its squared partial correlation ``rho2`` in [0, 1] with the
        new column; ``("", 0.0)`` when nothing was accepted or a column is not finite.
    """
    names = {t.name for t in accepted}
    terms = list(terms)
    if not names or not any(t.name in names for t in terms):
        return "", 0.0
    linear, columns = _columns(signals, terms + [new], free_body)
    if not all(np.all(np.isfinite(c)) for c in columns):
        return "", 0.0
    best = ("", 0.0)
    for k, term in enumerate(terms):
        if term.name not in names:
            continue
        others = linear + [c for j, c in enumerate(columns[:-1]) if j != k]
        r_new, r_k = _left_over(columns[-1], others), _left_over(columns[k], others)
        power = float(r_new @ r_new) * float(r_k @ r_k)
        rho2 = float(r_new @ r_k) ** 2 / power if power > 0 else 0.0
        if rho2 > best[1]:
            best = (term.name, min(rho2, 1.0))
    return best
