"""Model order and block rows of the subspace step: order choice and stabilisation diagrams (docs/method.md §3)."""

from __future__ import annotations

import numpy as np

from ..exceptions import BlockRowsError, OrderError, OrderWarning
from ..findings import Finding, emit
from ..noise import column_std, row_var
from ..signals import Signals
from . import _hankel, _subspace
from .feedback import as_candidate, extended_input
from .physics import split_poles

__all__ = [
    "auto_order", "check_block_rows", "oblique_decomposition", "order_findings", "order_note", "scaled_stack",
    "select_order", "stabilization",
]


def select_order(singular_values: np.ndarray, max_order: int, even: bool = True) -> int:
    """Model order at the largest gap of log σ (docs/method.md §3).

    Parameters
    ----------
    singular_values : ndarray, shape (k,)
        Singular values of the weighted oblique projection, in decreasing order.
    max_order : int
        Largest order considered.
    even : bool
        Consider only even orders (structural modes come in complex-conjugate pairs).

    Returns
    -------
    int
        The order ``n`` after which ``log σ_n - log σ_{n+1}`` is largest.

    Raises
    ------
    OrderError
        When no order up to ``max_order`` is admissible.

    Examples
    --------
    >>> select_order(np.array([10.0, 9.0, 8.0, 7.0, 1e-3, 1e-4]), max_order=4)
    4
    """
    s = np.asarray(singular_values, dtype=float)
    s = np.maximum(s, s[0] * 1e-300)
    gaps = np.log(s[:-1]) - np.log(s[1:])  # gaps[n-1] = gap after order n
    orders = np.arange(1, len(s))
    keep = orders <= max_order
    if even:
        keep &= orders % 2 == 0
    if not keep.any():
        raise OrderError(f"no admissible order up to {max_order} for {len(s)} singular values")
    return int(orders[keep][np.argmax(gaps[keep])])


def auto_order(singular_values: np.ndarray, max_order: int) -> int:
    """``order = "auto"``: :func:`select_order`, with an :class:`~bayesnsi.exceptions.OrderWarning` from
    :func:`order_note` when a later gap is nearly as large."""
    order = select_order(singular_values, max_order)
    note = order_note(singular_values, order, max_order)
    if note is not None:
        emit([Finding("order.auto", note, values={"order": int(order), "max_order": int(max_order)})], OrderWarning,
             stacklevel=3)
    return order


LATER_GAP = 0.5
"""A gap after a higher order at least this fraction of the chosen one's makes :func:`order_note` speak."""

ORDER_NOTE_START = 'order "auto" took'
"""How every :func:`order_note` begins."""


def order_note(singular_values: np.ndarray, order: int, max_order: int, even: bool = True) -> str | None:
    """What ``order = "auto"`` may have missed: gaps after higher orders nearly as large as the chosen one.

    The largest gap of log σ follows the modes that dominate the response: a displacement record of
    modes spread over a decade (integrated accelerations of a beam: 30, 120 and 300 Hz) has its largest
    gap after the first mode, with the others' gaps close behind (a simulated swept-sine beam: 1.99 after
    order 2, 1.32 after 4, 1.77 after 14).

    Parameters
    ----------
    singular_values : ndarray, shape (k,)
        As :func:`select_order`.
    order : int
        The order it chose.
    max_order : int
        Largest order it considered.
    even : bool
        Even orders only.

    Returns
    -------
    str or None
        A sentence naming the later gaps (the order after which each falls, and its size against the
        chosen one's), or saying that the order is the largest considered; None when every later gap is
        below :data:`LATER_GAP` of the chosen one.
    """
    s = np.maximum(np.asarray(singular_values, dtype=float), float(singular_values[0]) * 1e-300)
    gaps = np.log(s[:-1]) - np.log(s[1:])
    if order >= max_order - (1 if even else 0):  # no gap stands out below the largest order allowed
        return (f"{ORDER_NOTE_START} {order}, the largest order it considers (max_order): the singular values "
                "show no clear gap below it, so the model may hold noise poles or lack modes; look at the "
                "stabilisation diagram and the data's FRF in the report, and set [nsi] order")
    chosen = gaps[order - 1]
    later = [n for n in range(order + 1, min(max_order, len(gaps)) + 1)
             if (not even or n % 2 == 0) and gaps[n - 1] >= LATER_GAP * chosen]
    if not later or chosen <= 0:
        return None
    listed = ", ".join(f"{n} ({gaps[n - 1] / chosen:.2f}x)" for n in later[:6])
    return (
        f"{ORDER_NOTE_START} {order}, at the largest gap of the singular values, but the gaps after order {listed} "
        "are nearly as large: the data may hold modes this model lacks; look at the stabilisation diagram and "
        "the data's FRF in the report, and set [nsi] order"
    )


def order_findings(outcomes) -> tuple[Finding, ...]:
    """The :func:`order_note` of each candidate that recorded one, with the candidate as its subject.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
        With ``name`` and ``findings`` (those recorded while it was identified).

    Returns
    -------
    tuple of Finding
        Kind ``"order.auto"``, message ``"'<name>': <note>"``, one per candidate and note.
    """
    return tuple(Finding("order.auto", f"{o.name!r}: {f.message}", o.name, "warning", f.values)
                 for o in outcomes for f in dict.fromkeys(o.findings) if f.kind == "order.auto")


def check_block_rows(n_samples: int, block_rows: int, n_channels: int) -> None:
    """Check that the Hankel matrices are wide enough for ``block_rows`` (j ≥ 2·i·k).

    Parameters
    ----------
    n_samples : int
        Record length.
    block_rows : int
        i, the number of block rows.
    n_channels : int
        k, inputs plus outputs of the extended-input system.

    Raises
    ------
    BlockRowsError
        When ``block_rows`` is not an integer ≥ 2 or the record is too short for it.
    """
    if not isinstance(block_rows, (int, np.integer)) or block_rows < 2:
        raise BlockRowsError(f"block_rows must be an integer ≥ 2, got {block_rows!r}")
    needed = 2 * block_rows * (n_channels + 1) - 1
    if n_samples < needed:
        raise BlockRowsError(
            f"{n_samples} samples are too few for {block_rows} block rows with {n_channels} channels "
            f"(need at least {needed}); use fewer block rows (at most "
            f"{max(2, (n_samples + 1) // (2 * (n_channels + 1)))}) or a longer record"
        )


def scaled_stack(u: np.ndarray, y: np.ndarray, block_rows: int) -> _hankel.ScaledStack:
    """``[u, y]`` with each channel scaled to unit standard deviation, after checking ``block_rows``.

    Parameters
    ----------
    u : ndarray, shape (N, m + q)
        Extended input.
    y : ndarray, shape (N, l)
        Outputs.
    block_rows : int
        i (checked by :func:`check_block_rows`).

    Returns
    -------
    _hankel.ScaledStack
        Holds the scales (``u_scale``, ``y_scale``), computed once here.
    """
    check_block_rows(len(u), block_rows, u.shape[1] + y.shape[1])
    rows = np.ascontiguousarray(np.asarray(u, dtype=float).T)  # fast per-channel reductions
    std, rms = np.sqrt(row_var(rows)), np.sqrt(np.einsum("ij,ij->i", rows, rows) / rows.shape[1])
    # a constant input (an offset term) has no spread: scaled by its size instead
    return _hankel.ScaledStack(u, y, np.where(std > 1e-12 * rms, std, rms), column_std(y))


def oblique_decomposition(stack: _hankel.ScaledStack, block_rows: int, route: str = "correlation", lagged=None):
    """Subspace data and SVD of the weighted oblique projection of a scaled ``[u, y]``.

    Parameters
    ----------
    stack : _hankel.ScaledStack
        Inputs and outputs with their channel scales.
    block_rows : int
        i.
    route : {"correlation", "lq"}
        Factor from the lagged products (Gram) or by an LQ decomposition of the data.
    lagged : ndarray, optional
        Precomputed lagged products for the correlation route.

    Returns
    -------
    data : _subspace.SubspaceData
    left : ndarray
        Left singular vectors.
    singular_values : ndarray, shape (i·l,)
    """
    n_in, n_out = stack.u.shape[1], stack.y.shape[1]
    if route == "correlation":
        factor = _hankel.gram_factor(stack, block_rows, n_in, lagged)
    else:
        factor = _hankel.lq_factor(stack, block_rows, n_in)
    data = _subspace.SubspaceData(factor, block_rows, n_in, n_out)
    left, singular_values = _subspace.oblique_svd(data)
    return data, left, singular_values


def stabilization(signals: Signals, candidate=None, *, block_rows: int = 40, orders=None, velocity_method="fourth"):
    """Poles against model order for a stabilisation diagram (docs/method.md §3, paper Figs. 3, 7, 11).

    Parameters
    ----------
    signals : Signals
        Measured forces and responses.
    candidate : CandidateModel, sequence of Term or (expr, at) pairs, or None
        As in :func:`bayesnsi.nsi.identify`.
    block_rows : int
        i, the number of block rows.
    orders : sequence of int, optional
        Default 2, 4, ..., min(i·l - 1, 40).
    velocity_method : str
        Differentiator for velocities the signals do not carry.

    Returns
    -------
    singular_values : ndarray
        Of the weighted oblique projection.
    diagram : list of (order, ndarray (k, 2) of (frequency_hz, damping_ratio), ndarray of spurious poles)
        One entry per order.
    """
    cand = as_candidate(candidate)
    u = extended_input(signals, cand.terms, velocity_method)
    y = np.asarray(signals.displacement)
    stack = scaled_stack(u, y, block_rows)
    _, left, singular_values = oblique_decomposition(stack, block_rows)
    limit = block_rows * y.shape[1] - 1
    orders = orders or range(2, min(limit, 40) + 1, 2)
    out = []
    for n in orders:
        A, _ = _subspace.system_matrices_ac(left, singular_values, n, y.shape[1])
        poles = np.log(np.linalg.eigvals(A).astype(complex)) / signals.dt
        modes, spurious = split_poles(poles, signals.dt)
        out.append((n, np.array([(m.frequency_hz, m.damping_ratio) for m in modes]).reshape(-1, 2), spurious))
    return singular_values, out
