"""Variable-projection refinement of the continuous model on the lines (FNSI, docs/method.md §11).

:func:`refine` searches the poles and C of a continuous model in real modal form, B and D solved
by weighted linear least squares for every trial (:class:`ModalProblem`). Each pair of poles is
parametrised by its natural frequency (log) and its damping ratio mapped into
``DAMPING_RANGE`` by a logistic function, so the search can neither leave the stable half-plane
nor run a pole onto the imaginary axis or off to infinity: every iterate is a stable model, and
the best one is kept (docs/method.md §11: parametrise for stability rather than reflect poles
afterwards).

With ``A_c = blockdiag([[σ_i, ω_i], [-ω_i, σ_i]])`` the resolvent is closed-form per pair,
``(sI - A_i)⁻¹ = [[s - σ_i, ω_i], [-ω_i, s - σ_i]] / ((s - σ_i)² + ω_i²)``, so no eigen-decomposition
or inverse is needed per trial. Everything that does not depend on the poles and C (scaled inputs,
weights, the right-hand side, the D columns of the design) is prepared once per refinement.
The numbers are those of the general weighted least squares (same design, same QR); only the
arithmetic is arranged differently.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg

from ._levenberg import levenberg_marquardt

__all__ = ["DAMPING_RANGE", "ModalProblem", "modal_start", "refine"]

DAMPING_RANGE = (1e-4, 0.995)
"""Damping ratios a refined pair can take (logistic map of its parameter; a pair of real poles starts near the top)."""


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


def modal_start(Ac: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Natural frequencies, damping ratios and modal C of a stable A_c, as refinement start.

    Complex pairs are kept; real poles (a subspace step's answer to a heavily damped or out-of-band
    dynamics) are joined two by two, neighbours by magnitude, into a pair of the same product and
    sum (damping ratio capped at the top of :data:`DAMPING_RANGE`), a lone one into a pair of its
    magnitude; their C columns are those of their eigenvectors. None for an unstable or singular A_c.

    Parameters
    ----------
    Ac : ndarray, shape (n, n)
    C : ndarray, shape (l, n)

    Returns
    -------
    (wn, zeta, C_modal) or None
        ``wn`` (p,) [rad/s], ``zeta`` (p,), ``C_modal`` (l, 2p) for the real modal form whose pair i
        is ``[[σ_i, ω_i], [-ω_i, σ_i]]``, ordered by natural frequency.
    """
    lam, vec = np.linalg.eig(Ac)
    if not np.all(np.isfinite(lam)) or np.any(lam.real >= 0) or np.any(np.abs(lam) == 0):
        return None
    lo, hi = DAMPING_RANGE
    upper = lam.imag > 1e-9 * np.abs(lam)
    real = np.abs(lam.imag) <= 1e-9 * np.abs(lam)
    wn, zeta, columns = [], [], []
    for k in np.flatnonzero(upper):
        wn.append(abs(lam[k]))
        zeta.append(float(np.clip(-lam[k].real / abs(lam[k]), lo, hi)))
        cv = C @ vec[:, k]
        columns.append((cv.real, cv.imag))
    reals = np.flatnonzero(real)
    reals = reals[np.argsort(np.abs(lam[reals].real))]
    for i in range(0, len(reals), 2):
        group = reals[i : i + 2]
        p = np.abs(lam[group].real)
        w = float(np.sqrt(np.prod(p))) if len(group) == 2 else float(p[0])
        wn.append(w)
        zeta.append(float(np.clip(np.sum(p) / (2 * w), lo, hi)) if len(group) == 2 else hi)
        cols = [np.real(C @ vec[:, g]) for g in group]
        columns.append((cols[0], cols[1] if len(cols) == 2 else np.zeros_like(cols[0])))
    order = np.argsort(wn)
    C_modal = np.empty((C.shape[0], 2 * len(wn)))
    for i, k in enumerate(order):
        C_modal[:, 2 * i], C_modal[:, 2 * i + 1] = columns[k]
    return np.asarray(wn)[order], np.asarray(zeta)[order], C_modal


def _pairs(a: np.ndarray, b: np.ndarray, wn_bounds):
    """Damping ratio, natural frequency, σ and ω of each pair from the parameters (see :func:`refine`)."""
    lo, hi = DAMPING_RANGE
    s = 0.5 * (1.0 + np.tanh(0.5 * a))  # logistic, without overflow
    zeta = lo + (hi - lo) * s
    wn = np.exp(np.clip(b, *wn_bounds))
    return zeta, wn, s, -zeta * wn, wn * np.sqrt(1.0 - zeta**2)


def _logit(zeta: np.ndarray) -> np.ndarray:
    lo, hi = DAMPING_RANGE
    s = np.clip((zeta - lo) / (hi - lo), 1e-9, 1 - 1e-9)
    return np.log(s / (1 - s))


def refine(inputs, outputs, sigma, s, Ac, C, zero_feedthrough: bool, max_nfev: int = 200) -> tuple | None:
    """Weighted least-squares refinement of A_c and C on the lines (variable projection, module notes).

    Parameters
    ----------
    inputs, outputs, sigma, s, zero_feedthrough
        As :class:`ModalProblem` (``s = jω_k``).
    Ac, C : ndarray
        Start (stable; real poles are joined into pairs, :func:`modal_start`).
    max_nfev : int
        Largest number of residual evaluations of the Levenberg-Marquardt search.

    Returns
    -------
    (A_c, C, B, D, whitened residual, cost) or None
        The refined model in real modal form (pairs ordered by natural frequency) when it fits the
        lines better than the start, None otherwise (or for a start :func:`modal_start` refuses).
    """
    start_form = modal_start(Ac, C)
    if start_form is None:
        return None
    wn0, zeta0, C_modal = start_form
    n_pairs, n_out = len(wn0), C.shape[0]
    omega_lines = np.abs(s)
    wn_bounds = (float(np.log(1e-3 * max(omega_lines.min(), 1e-9))), float(np.log(1e3 * omega_lines.max())))
    problem = ModalProblem(inputs, outputs, sigma, s, zero_feedthrough)
    cache: dict = {}

    def parts(theta):
        return _pairs(theta[:n_pairs], theta[n_pairs : 2 * n_pairs], wn_bounds)

    def fitted(theta):
        key = theta.tobytes()
        if key not in cache:
            cache.clear()
            *_, damping, omega = parts(theta)
            cache[key] = problem.fit(damping, omega, theta[2 * n_pairs :].reshape(n_out, -1))
        return cache[key]

    def residual(theta):
        res = fitted(theta)["residual"]
        return np.concatenate([res.real.ravel(), res.imag.ravel()])

    def jacobian(theta):
        zeta, wn, logistic, damping, omega = parts(theta)
        J = problem.jacobian(fitted(theta), np.ones(n_pairs))  # columns: ∂/∂σ_i, ∂/∂ω_i, ∂/∂C
        d_sigma, d_omega = J[:, :n_pairs], J[:, n_pairs : 2 * n_pairs]
        dz = (DAMPING_RANGE[1] - DAMPING_RANGE[0]) * logistic * (1 - logistic)
        by_a = d_sigma * (-wn * dz) + d_omega * (-wn * zeta / np.sqrt(1.0 - zeta**2) * dz)
        by_b = d_sigma * damping + d_omega * omega
        return np.hstack([by_a, by_b, J[:, 2 * n_pairs :]])

    start = np.concatenate([_logit(zeta0), np.log(wn0), C_modal.ravel()])
    # the gauge: a pair's C columns times [[a, b], [-b, a]] (B times its inverse) leave the fit unchanged;
    # fixing each pair's entries on its strongest output removes that 2-parameter freedom per pair
    pivot = np.argmax(np.abs(C_modal[:, 0::2]) + np.abs(C_modal[:, 1::2]), axis=0)
    free = np.ones(start.size, dtype=bool)
    for i, o in enumerate(pivot):
        free[2 * n_pairs + o * C_modal.shape[1] + 2 * i : 2 * n_pairs + o * C_modal.shape[1] + 2 * i + 2] = False

    def embed(theta):
        full = start.copy()
        full[free] = theta
        return full

    cost0 = float(np.sum(residual(start) ** 2))
    x, _, _ = levenberg_marquardt(lambda t: residual(embed(t)), lambda t: jacobian(embed(t))[:, free], start[free],
                                  max_nfev=max_nfev)
    x = embed(x)
    cost = float(np.sum(residual(x) ** 2))
    best, best_cost = (x, cost) if np.isfinite(cost) and cost < cost0 else (start, cost0)
    if not np.isfinite(best_cost):
        return None
    return _assembled(best, fitted(best), parts, n_pairs, n_out) + (best_cost,)


def _assembled(theta, fit: dict, parts: Callable, n_pairs: int, n_out: int) -> tuple:
    """``(A_c, C, B, D, residual)`` of a parameter vector of :func:`refine`."""
    *_, damping, omega = parts(theta)
    A = np.zeros((2 * n_pairs, 2 * n_pairs))
    for i, (sig, om) in enumerate(zip(damping, omega)):
        A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = [[sig, om], [-om, sig]]
    return A, theta[2 * n_pairs :].reshape(n_out, -1), fit["B"], fit["D"], fit["residual"]
