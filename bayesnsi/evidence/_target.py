"""Unnormalised log posterior of one candidate in the sampling parameters (private).

Parameters ``θ = (λ_1..λ_q, u_1..u_l, φ_{1,1}..φ_{l,p})`` with ``u_j = log σ_j``. White noise
is the case ``p = 0`` of the AR form ``S_j = Σ_ik a_i a_k βᵀ W_{j,ik} β`` (see
:meth:`SufficientStatistics.window_gram`), so one set of formulas gives the log posterior, its
gradient and Hessian for every likelihood.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError, ShapeError
from ..options import parse_likelihood as _likelihood_order
from .likelihood import SufficientStatistics, _beta
from .priors import Priors

_LOG_2PI = float(np.log(2.0 * np.pi))


def parse_likelihood(likelihood: str) -> tuple[int, str]:
    """``"white"`` -> (0, "conditional"); ``"ar1"`` -> (1, "exact"); ``"arP"`` -> (P, "conditional")."""
    p = _likelihood_order(likelihood)[0]
    return p, "exact" if p == 1 else "conditional"


@dataclass(frozen=True)
class Target:
    """Log posterior of ``θ`` for given statistics, priors and likelihood."""

    stats: SufficientStatistics
    priors: Priors
    likelihood: str
    order: int
    method: str
    window: np.ndarray  # (l, p+1, p+1, q+1, q+1)

    @classmethod
    def build(cls, stats: SufficientStatistics, priors: Priors, likelihood: str = "white") -> Target:
        """Validate and precompute the window Gram matrices."""
        order, method = parse_likelihood(likelihood)
        if order > stats.ar_order:
            raise InputDataError(
                f"likelihood {likelihood!r} needs statistics with ar_order >= {order}, got {stats.ar_order}; "
                f"use sufficient_statistics(affine, ar_order={order})"
            )
        q, l = stats.n_coefficients, stats.n_channels
        if priors.coefficients.n_coefficients != q:
            raise ShapeError(f"coefficient prior has {priors.coefficients.n_coefficients} terms, the candidate has {q}")
        if priors.noise.n_channels != l:
            raise ShapeError(f"noise prior has {priors.noise.n_channels} channels, the data have {l}")
        if order == 0:
            window = stats.gram[:, None, None]
        else:
            window = stats.window_gram(order, method)
        return cls(stats=stats, priors=priors, likelihood=likelihood, order=order, method=method, window=window)

    # -- layout ---------------------------------------------------------------------------------
    @property
    def q(self) -> int:
        return self.stats.n_coefficients

    @property
    def l(self) -> int:  # noqa: E743
        return self.stats.n_channels

    @property
    def ndim(self) -> int:
        return self.q + self.l + self.l * self.order

    @property
    def n_eff(self) -> int:
        """Samples entering each channel's likelihood."""
        return self.stats.n_samples - (self.order if self.method == "conditional" else 0)

    @property
    def param_names(self) -> tuple[str, ...]:
        ch = self.priors.noise.channel_names
        names = list(self.stats.names) + [f"log_sigma[{c}]" for c in ch]
        if self.order == 1:
            names += [f"rho[{c}]" for c in ch]
        else:
            names += [f"rho[{c}, {k + 1}]" for c in ch for k in range(self.order)]
        return tuple(names)

    def split(self, theta):
        """``λ`` (..., q), ``u`` (..., l), ``φ`` (..., l, p)."""
        theta = np.asarray(theta, dtype=float)
        q, l, p = self.q, self.l, self.order
        lam = theta[..., :q]
        u = theta[..., q : q + l]
        rho = theta[..., q + l :].reshape(theta.shape[:-1] + (l, p))
        return lam, u, rho

    # -- densities ------------------------------------------------------------------------------
    def log_prior(self, theta) -> np.ndarray:
        lam, u, rho = self.split(theta)
        return self.priors.log_prior(lam, u, rho if self.order else None)

    def forms(self, lam) -> np.ndarray:
        """``βᵀ W_{j,ik} β`` for rows of ``λ``: (..., l, p+1, p+1), one product with the outer products ββᵀ.

        (A three-operand einsum over the windows loops in Python-speed steps; this is a matrix product.)
        """
        beta = _beta(np.asarray(lam, dtype=float) - self.stats.center)
        outer = (beta[..., :, None] * beta[..., None, :]).reshape(beta.shape[:-1] + (-1,))
        window = self.window
        return (outer @ window.reshape(-1, window.shape[-1] ** 2).T).reshape(beta.shape[:-1] + window.shape[:3])

    def log_likelihood(self, theta) -> np.ndarray:
        lam, u, rho = self.split(theta)
        forms = self.forms(lam)
        if self.order == 1:  # S(ρ) = A - 2ρB + ρ²C (the general contraction below, written out: 3x faster)
            r = rho[..., 0]
            ss = forms[..., 0, 0] - r * (forms[..., 0, 1] + forms[..., 1, 0]) + r * r * forms[..., 1, 1]
        else:
            taps = np.concatenate([np.ones(rho.shape[:-1] + (1,)), -rho], axis=-1)
            ss = np.einsum("...jk,...jk->...j", np.einsum("...ji,...jik->...jk", taps, forms), taps)
        out = -0.5 * self.n_eff * (_LOG_2PI + 2.0 * u) - 0.5 * ss * np.exp(-2.0 * u)
        if self.method == "exact" and self.order == 1:
            r2 = np.minimum(rho[..., 0] ** 2, 1.0)
            with np.errstate(divide="ignore"):
                out = out + np.where(r2 < 1.0, 0.5 * np.log1p(-r2), -np.inf)
        return np.sum(out, axis=-1)

    def log_posterior(self, theta) -> np.ndarray:
        """Vectorised ``log π(θ) + log L(θ)``; ``-inf`` outside the prior support."""
        theta = np.asarray(theta, dtype=float)
        lp = self.log_prior(theta)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            ll = self.log_likelihood(theta)
            out = lp + ll
        return np.where(np.isfinite(lp) & ~np.isnan(out), out, -np.inf)

    def value_grad_hess(self, theta):
        """Log posterior (interior form: no support limits), gradient and Hessian at one ``θ``."""
        theta = np.asarray(theta, dtype=float)
        q, l, p = self.q, self.l, self.order
        lam, u, rho = self.split(theta)
        beta = _beta(lam - self.stats.center)
        scale = self.priors.coefficients.scale
        value = float(self.priors.coefficients.log_pdf(lam))
        value -= float(np.sum(np.log(self.priors.noise.log_width)))
        if p:
            value -= l * p * float(np.log(self.priors.ar.upper - self.priors.ar.lower))
        grad = np.zeros(self.ndim)
        hess = np.zeros((self.ndim, self.ndim))
        grad[:q] = -lam / scale**2
        hess[:q, :q] = -np.diag(1.0 / scale**2)
        n = self.n_eff
        for j in range(l):
            a = np.concatenate([[1.0], -rho[j]])
            W = self.window[j]
            M = np.einsum("i,k,ikab->ab", a, a, W)
            Mb = M @ beta
            S = float(beta @ Mb)
            w = float(np.exp(-2.0 * u[j]))
            iu = q + j
            value += -0.5 * n * (_LOG_2PI + 2.0 * u[j]) - 0.5 * w * S
            grad[:q] += w * Mb[1:]
            grad[iu] += -n + w * S
            hess[:q, :q] += -w * M[1:, 1:]
            hess[:q, iu] += -2.0 * w * Mb[1:]
            hess[iu, :q] = hess[:q, iu]
            hess[iu, iu] += -2.0 * w * S
            if not p:
                continue
            V = np.einsum("k,mkab->mab", a, W[1:])  # (p, q+1, q+1): V_m = Σ_k a_k W_mk
            Vb = V @ beta
            VtB = np.swapaxes(V, -1, -2) @ beta
            bVb = Vb @ beta  # (p,)
            idx = q + l + j * p + np.arange(p)
            cp = np.zeros(p)
            cpp = np.zeros((p, p))
            if self.method == "exact":
                r = rho[j, 0]
                value += 0.5 * np.log1p(-r * r)
                cp[0] = -r / (1 - r * r)
                cpp[0, 0] = -(1 + r * r) / (1 - r * r) ** 2
            grad[idx] += cp + w * bVb
            cross = -w * (Vb + VtB)[:, 1:]  # (p, q)
            hess[np.ix_(idx, np.arange(q))] += cross
            hess[np.ix_(np.arange(q), idx)] += cross.T
            hess[idx, iu] += -2.0 * w * bVb
            hess[iu, idx] += -2.0 * w * bVb
            bWb = np.einsum("a,mnab,b->mn", beta, W[1:, 1:], beta)
            hess[np.ix_(idx, idx)] += cpp - w * 0.5 * (bWb + bWb.T)
        return value, grad, hess

    # -- starting point and mode ----------------------------------------------------------------
    def initial_theta(self, coefficients=None) -> np.ndarray:
        """``θ`` at the given coefficients (default: the NSI estimate), ``σ`` and ``φ`` from the residual."""
        lam = self.stats.center if coefficients is None else np.asarray(coefficients, dtype=float)
        if lam.shape != (self.q,):
            raise ShapeError(f"start coefficients must have shape ({self.q},), found {lam.shape}")
        beta = _beta(lam - self.stats.center)
        lagged = np.einsum("a,jkab,b->jk", beta, self.stats.lagged, beta)  # (l, P+1)
        var = np.maximum(lagged[:, 0] / self.stats.n_samples, 1e-300)
        lo, hi = np.log(self.priors.noise.lower), np.log(self.priors.noise.upper)
        u = np.clip(0.5 * np.log(var), lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo))
        rho = np.zeros((self.l, self.order))
        if self.order:
            r1 = lagged[:, 1] / np.maximum(lagged[:, 0], 1e-300)
            rho[:, 0] = np.clip(r1, self.priors.ar.lower + 1e-3, self.priors.ar.upper - 1e-3)
        return np.concatenate([lam, u, rho.reshape(-1)])

    def find_mode(self, theta0, max_iter: int = 200, tol: float = 1e-10):
        """Posterior mode by damped Newton steps; returns ``(θ*, value, Hessian, converged)``."""
        theta = np.array(theta0, dtype=float)
        value, grad, hess = self._vgh_safe(theta)
        converged = False
        for _ in range(max_iter):
            step = _ascent_direction(grad, hess)
            decrement = float(grad @ step)
            if decrement < tol:
                converged = True
                break
            t = 1.0
            while t > 1e-12:
                trial = theta + t * step
                v_new, g_new, h_new = self._vgh_safe(trial)
                if np.isfinite(v_new) and v_new >= value - 1e-12 * abs(value):
                    break
                t *= 0.5
            else:
                break
            theta, value, grad, hess = trial, v_new, g_new, h_new
        return theta, value, hess, converged

    def _vgh_safe(self, theta):
        if self.order and self.method == "exact" and np.any(np.abs(self.split(theta)[2]) >= 1.0):
            return -np.inf, np.zeros(self.ndim), np.zeros((self.ndim, self.ndim))
        with np.errstate(over="ignore", invalid="ignore"):  # a trial step far out: inf/NaN, rejected by find_mode
            return self.value_grad_hess(theta)

    def in_support(self, theta) -> np.ndarray:
        return np.isfinite(self.log_prior(theta))


def _ascent_direction(grad: np.ndarray, hess: np.ndarray) -> np.ndarray:
    """Newton direction ``(-H)⁻¹ g``, with eigenvalues of ``-H`` floored when not positive."""
    neg = -0.5 * (hess + hess.T)
    try:
        chol = np.linalg.cholesky(neg)
        return np.linalg.solve(chol.T, np.linalg.solve(chol, grad))
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(neg)
        floor = max(1e-8 * float(np.max(np.abs(vals))), 1e-300)
        vals = np.maximum(np.abs(vals), floor)
        return vecs @ ((vecs.T @ grad) / vals)
