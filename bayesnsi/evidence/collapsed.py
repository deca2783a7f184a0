"""The evidence with the noise parameters integrated out: sampling in the coefficients alone (docs/method.md §6).

For white and exact AR(1) residuals the integral of the likelihood over each channel's noise level
``σ_j`` (log-uniform on ``[lo_j, hi_j]``) is closed form given the innovation sum of squares
``S_j``, and ``S_j`` is a quadratic in the channel's AR coefficient ``ρ_j``; the integral over ``ρ_j``
(uniform) is one-dimensional and done by Gauss-Hermite quadrature. So the posterior of ``λ`` alone,

.. math:: p(λ | y) ∝ π(λ) \\prod_j \\iint L_j(λ, σ_j, ρ_j)\\, π(σ_j)\\, π(ρ_j)\\, dσ_j\\, dρ_j,

(docs/method.md §6, Eq. 6.4) is known pointwise at O(l q²) cost whatever N, and emcee samples ``q``
parameters instead of ``q + l(1 + p)``: the evidence is the same integral, with less Monte-Carlo
error. ``σ_j`` and ``ρ_j`` of every draw are then drawn exactly from their conditional posterior
given ``λ`` (a Student-t proposal with rejection for ``ρ``, a truncated gamma for ``σ⁻²``), so the
posterior draws hold every parameter, as before.

Per channel (``n`` samples, ``a = n/2``), with ``x_lo = S/(2 hi²)``, ``x_hi = S/(2 lo²)`` and ``P`` the
regularised lower incomplete gamma function:

.. math:: \\int_{lo}^{hi} (2πσ²)^{-n/2} e^{-S/2σ²} \\frac{dσ}{σ \\log(hi/lo)}
          = \\frac{Γ(a)\\,[P(a, x_{hi}) - P(a, x_{lo})]}{2 (πS)^{a} \\log(hi/lo)}.
"""

from __future__ import annotations

import numpy as np
from scipy.special import gammainc, gammaincc, gammaincinv, gammaln, logsumexp

from ._target import _LOG_2PI, Target

_SAFE_SD = 10.0  # a noise-prior bound more than 10 sd of Gamma(a) from the mass leaves it whole (< e^-45)
_GH_NODES = 12  # Gauss-Hermite nodes in ρ: exact for a Gaussian, < 1e-9 nat for the t-shape at n >= 100
_GL_NODES = 64  # Gauss-Legendre nodes on the truncated interval when ρ lies near a prior bound
_RHO_MARGIN_SD = 8.0  # GH is used when ρ̂ lies farther than this (in posterior sd) from a bound
_SERIES_MIN_N = 50  # below, the ρ integral is always done by quadrature
_QUADRATURE_BLOCK = 8192  # integrals per block of the node arrays (x 64 nodes: 4 MB each, whatever the draws)
_GH_X, _GH_W = np.polynomial.hermite.hermgauss(_GH_NODES)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(_GL_NODES)


def collapsible(target: Target) -> bool:
    """Whether the noise parameters of ``target`` integrate out (white, or exact AR(1))."""
    return target.order == 0 or (target.order == 1 and target.method == "exact")


class CollapsedTarget:
    """Log posterior of ``λ`` with ``σ`` (and ``ρ``) integrated out; duck-types :class:`Target` for sampling."""

    def __init__(self, target: Target, series: bool = True):
        self.target = target
        self.series = series  # False: the ρ integral always by quadrature (exact references)
        self.priors = target.priors
        self.q = target.q
        self.ndim = target.q
        self.l = target.l
        self.n = float(target.n_eff)
        noise = target.priors.noise
        self.lo2, self.hi2 = noise.lower**2, noise.upper**2
        const = -0.5 * self.n * _LOG_2PI - np.log(noise.log_width)
        if target.order:
            const = const - np.log(target.priors.ar.upper - target.priors.ar.lower)
        self.const = float(np.sum(const))

    # -- densities ------------------------------------------------------------------------------
    def forms(self, lam) -> np.ndarray:
        """``βᵀ W_{j,ik} β``: (..., l) for white noise, (..., l, 2, 2) for AR(1) (:meth:`Target.forms`)."""
        f = self.target.forms(lam)
        return f[..., 0, 0] if not self.target.order else f

    def log_posterior(self, lam) -> np.ndarray:
        """``log π(λ) + Σ_j log ∫∫ L_j π(σ_j) π(ρ_j)`` for rows of ``λ``; ``-inf`` where it vanishes."""
        lam = np.asarray(lam, dtype=float)
        f = self.forms(lam)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if not self.target.order:
                per = self._log_sigma_integral(f)
            else:
                per = self._log_rho_integral(f[..., 0, 0], f[..., 0, 1], f[..., 1, 1])
            out = self.priors.coefficients.log_pdf(lam) + self.const + np.sum(per, axis=-1)
        return np.where(np.isnan(out), -np.inf, out)

    def _log_sigma_integral(self, s: np.ndarray, lo2=None, hi2=None) -> np.ndarray:
        """``log ∫ σ^{-n} e^{-S/2σ²} dσ/σ`` over the prior range of each channel, (..., l)."""
        a = 0.5 * self.n
        s = np.maximum(s, 1e-300)
        lo2 = self.lo2 if lo2 is None else lo2
        hi2 = self.hi2 if hi2 is None else hi2
        whole = -np.log(2.0) + a * np.log(2.0 / s) + gammaln(a)
        return whole + _log_mass(a, 0.5 * s / hi2, 0.5 * s / lo2)

    def _log_rho_integral(self, A, B, C) -> np.ndarray:
        """``log ∫ √(1-ρ²) ∫ σ^{-n} e^{-S(ρ)/2σ²} dσ/σ dρ`` with ``S(ρ) = A - 2Bρ + Cρ²``, (..., l)."""
        lower, upper = self.priors.ar.lower, self.priors.ar.upper
        C = np.maximum(C, 1e-300)
        rho_hat = B / C
        m = np.maximum(A - B * rho_hat, 1e-300 * np.maximum(A, 1e-300))
        inside = np.clip(rho_hat, -0.999999, 0.999999)
        # curvature in ρ at ρ̂: C/σ² with σ the innovation level, held inside the noise prior's range
        curv = C / np.clip(m / self.n, self.lo2, self.hi2) + (1 + inside**2) / (1 - inside**2) ** 2
        sd = 1.0 / np.sqrt(curv)
        near = (rho_hat - _RHO_MARGIN_SD * sd < lower) | (rho_hat + _RHO_MARGIN_SD * sd > upper)
        a = 0.5 * self.n
        if self.n >= _SERIES_MIN_N and self.series:
            fast = ~near & _safe(a, 0.5 * m / self.hi2, 0.5 * m * (1.0 + 128.0 / self.n) / self.lo2)
            out = self._log_rho_series(m, C, rho_hat)
            if not np.all(fast):  # quadrature where ρ̂ lies near a bound or σ near its prior limits
                slow = ~fast
                lo2, hi2 = np.broadcast_to(self.lo2, m.shape)[slow], np.broadcast_to(self.hi2, m.shape)[slow]
                out[slow] = self._log_rho_quadrature(m[slow], C[slow], rho_hat[slow], sd[slow], near[slow], lo2, hi2)
            return out
        lo2, hi2 = (np.broadcast_to(v, m.shape) for v in (self.lo2, self.hi2))
        return self._log_rho_quadrature(m, C, rho_hat, sd, near, lo2, hi2)

    def _log_rho_quadrature(self, m, C, rho_hat, sd, near, lo2, hi2) -> np.ndarray:
        """:meth:`_log_rho_nodes` over blocks of :data:`_QUADRATURE_BLOCK` integrals (the nodes' arrays stay small).

        All arguments share one shape; so does the result.
        """
        args = [np.ravel(np.asarray(v, dtype=float)) for v in (m, C, rho_hat, sd, lo2, hi2)]
        flat_near = np.ravel(near)
        out = np.empty(args[0].size)
        for start in range(0, out.size, _QUADRATURE_BLOCK):
            block = slice(start, start + _QUADRATURE_BLOCK)
            mb, cb, rb, sb, lb, hb = (v[block] for v in args)
            out[block] = self._log_rho_nodes(mb, cb, rb, sb, flat_near[block], lb, hb)
        return out.reshape(np.shape(m))

    def _log_rho_nodes(self, m, C, rho_hat, sd, near, lo2, hi2) -> np.ndarray:
        """The ρ integral by Gauss-Hermite nodes, Gauss-Legendre on the truncated interval where ``near``."""
        lower, upper = self.priors.ar.lower, self.priors.ar.upper
        nodes = rho_hat[..., None] + np.sqrt(2.0) * sd[..., None] * _GH_X
        logw = np.log(_GH_W) + _GH_X**2 + np.log(np.sqrt(2.0) * sd)[..., None]
        if np.any(near):  # truncated interval, Gauss-Legendre
            lo_edge = np.maximum(lower, np.minimum(rho_hat, upper) - 12.0 * sd)
            hi_edge = np.minimum(upper, np.maximum(rho_hat, lower) + 12.0 * sd)
            half = 0.5 * (hi_edge - lo_edge)
            gl_nodes = (0.5 * (hi_edge + lo_edge))[..., None] + half[..., None] * _GL_X
            gl_logw = np.log(half)[..., None] + np.log(_GL_W)
            pad = _GL_NODES - _GH_NODES
            nodes = np.concatenate([nodes, np.broadcast_to(rho_hat[..., None], nodes.shape[:-1] + (pad,))], axis=-1)
            logw = np.concatenate([logw, np.full(logw.shape[:-1] + (pad,), -np.inf)], axis=-1)
            nodes = np.where(near[..., None], gl_nodes, nodes)
            logw = np.where(near[..., None], gl_logw, logw)
        s = C[..., None] * (nodes - rho_hat[..., None]) ** 2 + m[..., None]
        h = 0.5 * np.log1p(-np.minimum(nodes**2, 1.0)) + self._log_sigma_integral(s, lo2[..., None], hi2[..., None])
        h = np.where((nodes > lower) & (nodes < upper), h, -np.inf)
        return logsumexp(h + logw, axis=-1)

    def _log_rho_series(self, m, C, rho_hat) -> np.ndarray:
        """The ρ integral where the prior bounds hold all the mass: t-integral times ``E[√(1-ρ²)]``.

        ``∫ (C(ρ-ρ̂)² + m)^{-a} dρ = m^{-a} √(π m/C) Γ(a-½)/Γ(a)``, the normaliser of a Student-t with
        ``ν = 2a-1``; ``√(1-ρ²)`` is averaged under that t by its Taylor series to fourth order
        (moments ``Var = m/(C(ν-2))``, ``E x⁴ = 3 Var² (ν-2)/(ν-4)``; the remainder is O(n⁻³)).
        """
        a = 0.5 * self.n
        nu = 2.0 * a - 1.0
        var = m / (C * (nu - 2.0))
        e4 = 3.0 * var**2 * (nu - 2.0) / (nu - 4.0)
        r2 = rho_hat**2
        w = 1.0 - r2
        root = np.sqrt(w)
        inv = 1.0 / (w * root)  # w^-1.5 (products: numpy's float ** -1.5 calls pow(), several times slower)
        mean_g = root - 0.5 * var * inv - (3.0 * (1.0 + 4.0 * r2) / 24.0) * e4 * (inv / (w * w))
        constant = -np.log(2.0) + a * np.log(2.0) + gammaln(a - 0.5) + 0.5 * np.log(np.pi)
        return constant + (0.5 - a) * np.log(m) - 0.5 * np.log(C) + np.log(mean_g)

    # -- conditional draws of the noise parameters ----------------------------------------------
    def draw_noise(self, lam: np.ndarray, rng: np.random.Generator):
        """Exact draws of ``log σ`` (M, l) and ``ρ`` (M, l, p) from their posterior given rows of ``λ`` (M, q)."""
        f = self.forms(lam)
        if not self.target.order:
            return self._draw_log_sigma(f, rng), np.zeros(f.shape + (0,))
        A, B, C = f[..., 0, 0], f[..., 0, 1], np.maximum(f[..., 1, 1], 1e-300)
        rho_hat = B / C
        m = np.maximum(A - B * rho_hat, 1e-300)
        nu = self.n - 1.0
        scale = np.sqrt(m / (C * nu))
        lower, upper = self.priors.ar.lower, self.priors.ar.upper
        rho = np.clip(rho_hat, lower + 1e-9, upper - 1e-9)
        # envelope: the largest √(1-ρ²) within 8 sd of ρ̂ (the t beyond holds < 1e-14 of the mass: ν = n-1)
        reach = 8.0 * scale * np.sqrt(nu / max(nu - 2.0, 1.0))
        closest = np.where(np.abs(rho_hat) <= reach, 0.0, np.abs(rho_hat) - reach)
        log_env = 0.5 * np.log1p(-np.minimum(closest, 1.0 - 1e-16) ** 2)
        flat = [np.ravel(v) for v in (rho_hat, scale, C, m, log_env)]
        lo2, hi2 = (np.ravel(np.broadcast_to(v, rho.shape)) for v in (self.lo2, self.hi2))
        out = rho.reshape(-1)  # a copy: rho came from np.clip
        pending = np.arange(out.size)
        columns = [*flat, lo2, hi2]
        for attempt in range(40):  # rejection rounds over the draws still pending
            if not pending.size:
                break
            # the first round takes every draw: no gather
            r_hat, sc, c2, m2, env, l2, h2 = columns if attempt == 0 else (v[pending] for v in columns)
            prop = r_hat + sc * rng.standard_t(nu, size=pending.size)
            s = c2 * (prop - r_hat) ** 2 + m2
            with np.errstate(divide="ignore", invalid="ignore"):
                log_acc = 0.5 * np.log1p(-np.minimum(prop**2, 1.0)) + _log_mass(0.5 * self.n, 0.5 * s / h2,
                                                                                 0.5 * s / l2)
            ok = (prop > lower) & (prop < upper) & (np.log(rng.uniform(size=pending.size)) < log_acc - env)
            out[pending[ok]] = prop[ok]
            pending = pending[~ok]
        for start in range(0, pending.size, 4096):  # σ̂ far outside its prior: the t misses; inverse CDF on a grid
            rows = pending[start : start + 4096]
            out[rows] = self._grid_rho(flat[0][rows], flat[2][rows], flat[3][rows], lo2[rows], hi2[rows], rng)
        rho = out.reshape(rho.shape)
        s = C * (rho - rho_hat) ** 2 + m
        return self._draw_log_sigma(s, rng), rho[..., None]

    def _grid_rho(self, rho_hat, C, m, lo2, hi2, rng, nodes: int = 512) -> np.ndarray:
        """Draws of ρ from its density given λ tabulated on ``ρ̂ ± 12 sd`` (sd with σ held in its prior range)."""
        lower, upper = self.priors.ar.lower, self.priors.ar.upper
        sd = np.sqrt(np.clip(m / self.n, lo2, hi2) / C)
        lo_edge = np.maximum(lower, np.minimum(rho_hat, upper) - 12.0 * sd)
        hi_edge = np.minimum(upper, np.maximum(rho_hat, lower) + 12.0 * sd)
        grid = lo_edge[:, None] + (hi_edge - lo_edge)[:, None] * np.linspace(0.0, 1.0, nodes)
        s = C[:, None] * (grid - rho_hat[:, None]) ** 2 + m[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            h = 0.5 * np.log1p(-np.minimum(grid**2, 1.0)) + self._log_sigma_integral(s, lo2[:, None], hi2[:, None])
        w = np.exp(h - np.max(h, axis=1, keepdims=True))
        cdf = np.cumsum(0.5 * (w[:, 1:] + w[:, :-1]), axis=1)  # trapezoid cells
        u = rng.uniform(size=len(grid)) * cdf[:, -1]
        cell = np.minimum(np.sum(cdf < u[:, None], axis=1), nodes - 2)
        return grid[np.arange(len(grid)), cell] + rng.uniform(size=len(grid)) * (grid[:, 1] - grid[:, 0])

    def _draw_log_sigma(self, s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``log σ`` with ``S/(2σ²) ~ Gamma(n/2)`` truncated to the prior range."""
        a = 0.5 * self.n
        s = np.maximum(s, 1e-300)
        x_lo, x_hi = 0.5 * s / self.hi2, 0.5 * s / self.lo2
        t = rng.gamma(a, size=s.shape)
        cut = ~_safe(a, x_lo, x_hi)
        if np.any(cut):
            xl, xh = np.broadcast_to(x_lo, s.shape)[cut], np.broadcast_to(x_hi, s.shape)[cut]
            p_lo, p_hi = gammainc(a, xl), gammainc(a, xh)
            tt = gammaincinv(a, p_lo + (p_hi - p_lo) * rng.uniform(size=xl.size))
            bad = ~np.isfinite(tt) | (p_hi <= p_lo)
            tt = np.where(bad, np.clip(a, xl, xh), tt)
            t[cut] = np.clip(tt, xl, xh)
        return 0.5 * np.log(0.5 * s / t)


def _safe(a: float, x_lo, x_hi) -> np.ndarray:
    """Where the prior range of ``σ`` holds the whole mass of the ``Gamma(a)`` integrand."""
    width = _SAFE_SD * np.sqrt(a)
    return (x_lo <= a - width) & (x_hi >= a + width)


def _log_mass(a: float, x_lo, x_hi) -> np.ndarray:
    """``log [P(a, x_hi) - P(a, x_lo)]`` for ``x_lo < x_hi``, 0 where the range holds all the mass."""
    x_lo, x_hi = np.broadcast_arrays(np.asarray(x_lo, dtype=float), np.asarray(x_hi, dtype=float))
    out = np.zeros(x_lo.shape)
    cut = ~_safe(a, x_lo, x_hi)
    if not np.any(cut):
        return out
    xl, xh = x_lo[cut], x_hi[cut]
    upper_tail = xl > a
    diff = np.where(upper_tail, gammaincc(a, xl) - gammaincc(a, xh), gammainc(a, xh) - gammainc(a, xl))
    with np.errstate(divide="ignore"):
        value = np.log(np.maximum(diff, 0.0))
    tiny = ~(diff > 1e-280)
    above, below = tiny & upper_tail, tiny & ~upper_tail  # the mass lies beyond a bound: the tail by its series
    if np.any(above):
        value[above] = _log_q_tail(a, xl[above])
    if np.any(below):
        value[below] = _log_p_tail(a, xh[below])
    out[cut] = value
    return out


def _log_p_tail(a: float, x: np.ndarray) -> np.ndarray:
    """``log P(a, x)`` for ``x`` well below ``a``: ``x^a e^{-x}/Γ(a+1) Σ_k x^k/((a+1)..(a+k))``."""
    term = np.ones_like(x)
    total = np.ones_like(x)
    for k in range(1, 20000):
        term = term * x / (a + k)
        total += term
        if np.all(term < 1e-17 * total):
            break
    return a * np.log(x) - x - gammaln(a + 1) + np.log(total)


def _log_q_tail(a: float, x: np.ndarray) -> np.ndarray:
    """``log Q(a, x)`` for ``x`` well above ``a``: ``x^{a-1} e^{-x}/Γ(a) Σ_k (a-1)..(a-k)/x^k`` (asymptotic)."""
    term = np.ones_like(x)
    total = np.ones_like(x)
    for k in range(1, 2000):
        nxt = term * (a - k) / x
        if np.all(np.abs(nxt) >= np.abs(term)) or np.all(np.abs(nxt) < 1e-17 * np.abs(total)):
            break
        term = nxt
        total += term
    return (a - 1) * np.log(x) - x - gammaln(a) + np.log(np.abs(total))

