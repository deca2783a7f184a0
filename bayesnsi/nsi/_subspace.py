"""Combined deterministic-stochastic subspace steps on the Hankel factor (SPEC section 3).

Van Overschee & De Moor (1996), "Subspace Identification for Linear Systems", ch. 4:
oblique projection (Eq. 4.21 / paper Eq. 22), weighting W₂ = Π_{U_f⊥} (paper Eq. 23, the
"robust" algorithm, Fig. 4.8), A and C from the shift structure of Γ_i, and B, D by the robust
least squares of sec. 4.3.3. All row-space quantities are handled as rows of the factor ``L``
returned by :mod:`._hankel` (``L Lᵀ = H Hᵀ/j``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SubspaceData", "oblique_svd", "system_matrices_ac", "input_matrices_robust", "observability"]


@dataclass(frozen=True)
class SubspaceData:
    """Row blocks of the Hankel factor, grouped ``[U_p; U_f; Y_p; Y_f]``."""

    factor: np.ndarray
    block_rows: int
    n_inputs: int
    n_outputs: int

    def _rows(self, kind: str, first: int, last: int) -> np.ndarray:
        """Block rows ``first..last`` (inclusive, 0-based) of U or Y."""
        i, m, l = self.block_rows, self.n_inputs, self.n_outputs
        if kind == "u":
            return self.factor[first * m : (last + 1) * m]
        offset = 2 * i * m
        return self.factor[offset + first * l : offset + (last + 1) * l]

    def u(self, first, last):
        return self._rows("u", first, last)

    def y(self, first, last):
        return self._rows("y", first, last)


def _regress(target: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Coefficients Θ minimising ‖target - Θ basis‖ over rows (min-norm least squares)."""
    if basis.shape[0] == 0:
        return np.zeros((target.shape[0], 0))
    theta, *_ = np.linalg.lstsq(basis.T, target.T, rcond=None)
    return theta.T


def _project(target: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Orthogonal projection of the rows of ``target`` onto the row space of ``basis``."""
    return _regress(target, basis) @ basis


def oblique_svd(data: SubspaceData):
    """SVD of the weighted oblique projection ``O_i Π_{U_f⊥}`` (paper Eqs. 22-23).

    Returns
    -------
    left : ndarray, shape (i·l, i·l)
        Left singular vectors.
    singular_values : ndarray, shape (i·l,)
    """
    i = data.block_rows
    up, uf = data.u(0, i - 1), data.u(i, 2 * i - 1)
    yp, yf = data.y(0, i - 1), data.y(i, 2 * i - 1)
    wp = np.vstack([up, yp])
    theta = _regress(yf, np.vstack([wp, uf]))
    theta_w = theta[:, : wp.shape[0]]
    wp_perp = wp - _project(wp, uf)
    left, singular_values, _ = np.linalg.svd(theta_w @ wp_perp, full_matrices=False)
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
    up, uf = data.u(0, i - 1), data.u(i, 2 * i - 1)
    yp, yf = data.y(0, i - 1), data.y(i, 2 * i - 1)
    wp = np.vstack([up, yp])
    z_i = _project(yf, np.vstack([wp, uf]))
    wp_plus = np.vstack([data.u(0, i), data.y(0, i)])
    uf_minus = data.u(i + 1, 2 * i - 1)
    yf_minus = data.y(i + 1, 2 * i - 1)
    z_next = _project(yf_minus, np.vstack([wp_plus, uf_minus]))
    y_ii = data.y(i, i)

    gamma = observability(A, C, i)
    gamma_pinv = np.linalg.pinv(gamma)
    gamma_short_pinv = np.linalg.pinv(gamma[:-l])
    ac = np.vstack([A, C])
    lhs = np.vstack([gamma_short_pinv @ z_next, y_ii]) - ac @ (gamma_pinv @ z_i)
    kappa = _regress(lhs, uf)  # (n + l, i·m)

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
