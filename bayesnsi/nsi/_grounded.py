"""A fixed ``virtual_stiffness`` is for a free body: tell when a record's structure looks grounded.

``[nsi] virtual_stiffness = k`` adds a known spring ``k`` on the forced DOF before identifying
and removes it from the result (:mod:`bayesnsi.nsi.free_body`). On a free body that turns the
rigid-body pole (s = 0), which the subspace step cannot place, into an ordinary mode. On a
grounded structure there is no rigid-body pole to move: the spring is removed from a structure
that never had it, and the modes and coefficients come out wrong (a two-DOF record with
``k = 1e4``: one mode at 7.38 Hz instead of 2.46 and 7.51 Hz, a coefficient of -37.6 instead of
+20) while the run reports success. :func:`grounded_modes` identifies the underlying linear
model once without the spring: when it is stable, has physical modes and no rigid-body pole,
the structure looks grounded (:func:`grounded_modes`), and loading such a config warns loudly,
naming the modes found and what the spring would do (:func:`bayesnsi.io.load_signals`).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import BayesNSIError
from ..models import CandidateModel
from . import _subspace
from .feedback import extended_input, resolve_input_hold, working_signals
from .free_body import rigid_body_poles
from .order import auto_order, oblique_decomposition, scaled_stack
from .physics import split_poles

__all__ = ["grounded_modes"]


def grounded_modes(signals, options) -> tuple | None:
    """The modes of ``signals``' structure when it looks grounded, identified without any virtual spring.

    Parameters
    ----------
    signals : Signals
        The measured record.
    options : NSIOptions
        Block rows, order, route of the identification (``virtual_stiffness`` is ignored here).

    Returns
    -------
    tuple of Mode or None
        The physical modes of the linear model identified as the data are, when it is stable, has
        physical modes and no rigid-body pole (a grounded structure); None otherwise, or when that
        model cannot be identified at all.
    """
    try:
        eigenvalues, dt = _first_eigenvalues(signals, CandidateModel("linear", ()), options)
    except (BayesNSIError, np.linalg.LinAlgError, ValueError):
        return None
    if not len(eigenvalues) or np.max(np.abs(eigenvalues)) >= 1.0:
        return None
    if len(rigid_body_poles(eigenvalues, dt, signals.n_samples)):
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        modes, _ = split_poles(np.log(eigenvalues.astype(complex)) / dt, dt)
    return tuple(modes) or None


def _first_eigenvalues(signals, cand, options) -> tuple[np.ndarray, float]:
    """Eigenvalues of the underlying linear model identified from ``signals`` as they are (no spring)."""
    block_rows = options.block_rows
    working = working_signals(signals, int(options.upsample))
    u = extended_input(working, cand.terms, options.velocity_method, resolve_input_hold(options.input_hold, cand.terms))
    stack = scaled_stack(u, np.asarray(working.displacement), block_rows)
    _, left, singular_values = oblique_decomposition(stack, block_rows, options.route, None)
    n_out = stack.y.shape[1]
    limit = block_rows * n_out - 1
    auto = options.order == "auto"
    order = auto_order(singular_values, min(limit, options.max_order)) if auto else int(options.order)
    if not 1 <= order <= limit:
        return np.zeros(0), working.dt
    A, _ = _subspace.system_matrices_ac(left, singular_values, order, n_out)
    return np.linalg.eigvals(A), working.dt
