"""Combined deterministic-stochastic subspace steps on the Hankel factor (docs/method.md §3).

Van Overschee & De Moor (1996), "Subspace Identification for Linear Systems", ch. 4:
oblique projection (Eq. 4.21 / paper Eq. 22), weighting W₂ = Π_{U_f⊥} (paper Eq. 23, the
"robust" algorithm, Fig. 4.8), A and C from the shift structure of Γ_i, and B, D by the robust
least squares of sec. 4.3.3. All row-space quantities are handled as rows of the factor ``L``
returned by :mod:`._hankel` (``L Lᵀ = H Hᵀ/j``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular

__all__ = ["SubspaceData", "oblique_svd", "system_matrices_ac", "input_matrices_robust", "observability"]


@dataclass(frozen=True)
class SubspaceData:
    """The Hankel factor ``L`` with rows ``[U_f; U_p; Y_p; Y_f]`` and its block sizes.

    With this ordering and ``L`` lower triangular, the row space of the first ``p`` rows is the
    span of the first ``p`` coordinates, so projections onto ``[U_f]``, ``[U_f; W_p]`` and
    ``[U_{0|2i-1}; Y_{0|i}]`` are truncations (Van Overschee & De Moor 1996, sec. 6.1).
    """

    factor: np.ndarray
    block_rows: int
    n_inputs: int
    n_outputs: int

    @property
    def n_future_inputs(self) -> int:
        """Rows of U_f: i·m."""
        return self.block_rows * self.n_inputs

    @property
    def n_past(self) -> int:
        """Rows of [U_f; U_p; Y_p]: 2i·m + i·l."""
        return 2 * self.block_rows * self.n_inputs + self.block_rows * self.n_outputs

    def y(self, first: int, last: int) -> np.ndarray:
        """Output block rows ``first..last`` (inclusive, 0-based) of ``L``."""
        offset, l = 2 * self.block_rows * self.n_inputs, self.n_outputs
        return self.factor[offset + first * l : offset + (last + 1) * l]


def _triangular_regress(target: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Θ with ``target = Θ L`` for a lower-triangular square ``L`` (least squares on its rows)."""
    return solve_triangular(lower, target.T, lower=True, trans="T").T


def oblique_svd(data: SubspaceData):
    """SVD of the weighted oblique projection ``O_i Π_{U_f⊥}`` (paper Eqs. 22-23).

    In the coordinates of ``L`` this matrix is the block ``L[Y_f, U_p ∪ Y_p]``: the part of
    the future outputs explained by the past data after removing the future inputs.

    Returns
    -------
    left : ndarray, shape (i·l, i·l)
        Left singular vectors.
    singular_values : ndarray, shape (i·l,)
    """
    i = data.block_rows
    block = data.y(i, 2 * i - 1)[:, data.n_future_inputs : data.n_past]
    left, singular_values, _ = np.linalg.svd(block, full_matrices=False)
    return left, singular_values


def observability(A: np.ndarray, C: np.ndarray, block_rows: int) -> np.ndarray:
    """Extended observability matrix ``Γ_i = [C; CA; ...; CA^{i-1}]`` (paper Eq. 21)."""
    blocks, current = [], C
    for _ in range(block_rows):
        blocks.append(current)
        current = current @ A
    return np.vstack(blocks)


def system_matrices_ac(left: np.ndarray, singular_values: np.ndarray, order: int, n_outputs: int):
    """A and C from ``Γ_i = U₁ S₁^{1/2}`` by its shift structure (least squares).

    ``Γ_i[l:] = Γ_i[:-l] A`` and ``C = Γ_i[:l]``.
    """
    gamma = left[:, :order] * np.sqrt(singular_values[:order])
    A, *_ = np.linalg.lstsq(gamma[:-n_outputs], gamma[n_outputs:], rcond=None)
    return A, gamma[:n_outputs].copy()


def input_matrices_robust(data: SubspaceData, A: np.ndarray, C: np.ndarray, zero_feedthrough: bool):
    """B and D by the robust least squares of Van Overschee & De Moor (sec. 4.3.3).

    With Γ_i recomputed from (A, C), ``Z_i = Y_f/[W_p; U_f]`` and
    ``Z_{i+1} = Y_f⁻/[W_p⁺; U_f⁻]``::

        [Γ_{i-1}† Z_{i+1}; Y_{i|i}] - [A; C] Γ_i† Z_i = 𝒦(B, D) U_f + residual

    ``𝒦`` is linear in (B, D); it is estimated from the data, then B, D solve the stacked
    linear equations ``Σ_k N_k [B; D] = 𝒦_k`` (one block per future input block k).
    """
    i, m, l = data.block_rows, data.n_inputs, data.n_outputs
    n = A.shape[0]
    n_uf = data.n_future_inputs
    # Projections onto [W_p; U_f] and [W_p⁺; U_f⁻] are truncations of L; only the U_f
    # coordinates (the first i·m columns) enter the regression on U_f.
    z_i = data.y(i, 2 * i - 1)[:, :n_uf]
    z_next = data.y(i + 1, 2 * i - 1)[:, :n_uf]
    y_ii = data.y(i, i)[:, :n_uf]

    gamma = observability(A, C, i)
    gamma_pinv = np.linalg.pinv(gamma)
    gamma_short_pinv = np.linalg.pinv(gamma[:-l])
    ac = np.vstack([A, C])
    lhs = np.vstack([gamma_short_pinv @ z_next, y_ii]) - ac @ (gamma_pinv @ z_i)
    kappa = _triangular_regress(lhs, data.factor[:n_uf, :n_uf])  # (n + l, i·m), U_f = L[:i·m]

    # Linear map (B, D) -> 𝒦: block k of 𝒦 is N_B(k) B + N_D(k) D.
    rows_b, rows_d = [], []
    eye_n, eye_l = np.eye(n), np.eye(l)
    for k in range(i):
        # H_i column block k: D at block row k, C A^{p-k-1} B at block rows p > k.
        shift = np.zeros((i * l, n))
        shift[(k + 1) * l :] = gamma[: (i - k - 1) * l]
        select = np.zeros((i * l, l))
        select[k * l : (k + 1) * l] = eye_l
        nb = -ac @ (gamma_pinv @ shift)
        nd = -ac @ (gamma_pinv @ select)
        if k == 0:
            nb[:n] += eye_n
            nd[n:] += eye_l
        else:
            shift_short = np.zeros(((i - 1) * l, n))
            shift_short[k * l :] = gamma[: (i - 1 - k) * l]
            select_short = np.zeros(((i - 1) * l, l))
            select_short[(k - 1) * l : k * l] = eye_l
            nb[:n] += gamma_short_pinv @ shift_short
            nd[:n] += gamma_short_pinv @ select_short
        rows_b.append(nb)
        rows_d.append(nd)
    design = np.vstack(rows_b) if zero_feedthrough else np.hstack([np.vstack(rows_b), np.vstack(rows_d)])
    target = np.vstack([kappa[:, k * m : (k + 1) * m] for k in range(i)])
    solution, *_ = np.linalg.lstsq(design, target, rcond=None)
    B = solution[:n]
    D = np.zeros((l, m)) if zero_feedthrough else solution[n:]
    return B, D
