"""The inner loop of the FNSI refinement (:func:`bayesnsi.nsi._fnsi.refine`), vectorised for A_c in
real modal form.

With ``A_c = blockdiag([[σ_i, ω_i], [-ω_i, σ_i]])`` the resolvent is closed-form per pair,
``(sI - A_i)⁻¹ = [[s - σ_i, ω_i], [-ω_i, s - σ_i]] / ((s - σ_i)² + ω_i²)``, so no eigen-decomposition
or inverse is needed per trial. Everything that does not depend on the poles and C (scaled inputs,
weights, the right-hand side, the D columns of the design) is prepared once per refinement.
The numbers are those of the general weighted least squares (same design, same QR); only the
arithmetic is arranged differently.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["ModalProblem"]


class ModalProblem:
    """The weighted B, D least squares on the lines for modal A_c (prepared once per refinement).

    Parameters
    ----------
    inputs : ndarray, shape (M, m) complex
        Extended-input spectra on the lines.
    outputs : ndarray, shape (M, l) complex
        Output spectra.
    sigma : ndarray, shape (M, l)
        Noise std per line and channel (the weights are 1/σ).
    s : ndarray, shape (M,) complex
        Where the transfer function is evaluated (jω_k).
    zero_feedthrough : bool
        D = 0 when True.
    """

    def __init__(self, inputs, outputs, sigma, s, zero_feedthrough: bool):
        self.U, self.Y, self.sigma, self.s = inputs, outputs, sigma, s
        scale = np.sqrt(np.mean(np.abs(inputs) ** 2, axis=0))
        self.u_scale = np.where(scale > 0, scale, 1.0)
        self.Us = inputs / self.u_scale
        self.zero_feedthrough = zero_feedthrough
        n_lines, n_out = outputs.shape
        n_in = inputs.shape[1]
        target = outputs / sigma
        self.rhs = np.concatenate([target.real.ravel(), target.imag.ravel()])
        self.d_design = None
        if not zero_feedthrough:
            eye = np.eye(n_out)
            phi_d = np.einsum("kj,op->kojp", self.Us, eye).reshape(n_lines, n_out, n_in * n_out) / sigma[:, :, None]
            self.d_design = np.vstack([phi_d.real.reshape(-1, phi_d.shape[2]), phi_d.imag.reshape(-1, phi_d.shape[2])])

    def transfer(self, damping, omega, C):
        """``G = C (sI - A)⁻¹`` (M, l, n) and the per-pair resolvent parts ``(a, ω)/det`` for modal A."""
        a = self.s[:, None] - damping[None, :]  # (M, pairs)
        inv_det = 1.0 / (a**2 + omega[None, :] ** 2)
        ra, rw = a * inv_det, omega[None, :] * inv_det  # resolvent block [[ra, rw], [-rw, ra]]
        c0, c1 = C[:, 0::2], C[:, 1::2]  # (l, pairs)
        G = np.empty((len(self.s), C.shape[0], C.shape[1]), dtype=complex)
        G[:, :, 0::2] = c0[None] * ra[:, None, :] - c1[None] * rw[:, None, :]
        G[:, :, 1::2] = c0[None] * rw[:, None, :] + c1[None] * ra[:, None, :]
        return G, ra, rw

    def fit(self, damping, omega, C) -> dict:
        """B, D, the whitened residual and what the Jacobian reuses (G, X = (sI-A)⁻¹ B U, basis)."""
        n_lines, n_in = self.U.shape
        n_out, n = C.shape
        G, ra, rw = self.transfer(damping, omega, C)
        phi_b = (self.Us[:, None, :, None] * G[:, :, None, :]).reshape(n_lines, n_out, n_in * n)
        phi_b = phi_b / self.sigma[:, :, None]
        design = np.vstack([phi_b.real.reshape(-1, n_in * n), phi_b.imag.reshape(-1, n_in * n)])
        if self.d_design is not None:
            design = np.hstack([design, self.d_design])
        col = np.sqrt(np.einsum("ij,ij->j", design, design))
        col[col == 0] = 1.0
        q, r = scipy.linalg.qr(design / col, mode="economic", check_finite=False)
        theta = scipy.linalg.solve_triangular(r, q.T @ self.rhs, check_finite=False) / col
        B = theta[: n_in * n].reshape((n, n_in), order="F") / self.u_scale
        BU = self.U @ B.T  # (M, n)
        fitted = np.einsum("kon,kn->ko", G, BU)
        D = np.zeros((n_out, n_in))
        if not self.zero_feedthrough:
            D = theta[n_in * n :].reshape((n_out, n_in), order="F") / self.u_scale
            fitted = fitted + self.U @ D.T
        X = np.empty_like(BU)  # (sI - A)⁻¹ B U per line, pair by pair
        b0, b1 = BU[:, 0::2], BU[:, 1::2]
        X[:, 0::2] = ra * b0 + rw * b1
        X[:, 1::2] = -rw * b0 + ra * b1
        return dict(B=B, D=D, residual=(self.Y - fitted) / self.sigma, G=G, X=X, basis=q)

    def jacobian(self, fit: dict, damping) -> np.ndarray:
        """Kaufman's Jacobian of the projected residual for θ = (log(-σ_i), ω_i, C) (modal C)."""
        G, X, q = fit["G"], fit["X"], fit["basis"]
        n_lines, n_out, n = G.shape
        Ga, Gb = G[:, :, 0::2], G[:, :, 1::2]
        Xa, Xb = X[:, None, 0::2], X[:, None, 1::2]
        d_log_sigma = damping[None, None, :] * (Ga * Xa + Gb * Xb)  # σ_i ∂/∂σ_i
        d_omega = Ga * Xb - Gb * Xa
        d_c = np.zeros((n_lines, n_out, n_out, n), dtype=complex)  # ∂/∂C[o, c]: output o only
        idx = np.arange(n_out)
        d_c[:, idx, idx, :] = X[:, None, :]
        dy = np.concatenate([d_log_sigma, d_omega, d_c.reshape(n_lines, n_out, n_out * n)], axis=2)
        dy = dy / self.sigma[:, :, None]
        dy = np.vstack([dy.real.reshape(-1, dy.shape[-1]), dy.imag.reshape(-1, dy.shape[-1])])
        return -(dy - q @ (q.T @ dy))
