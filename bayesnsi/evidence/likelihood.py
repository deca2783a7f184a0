"""Gaussian likelihoods of an affine reconstruction from sufficient statistics (docs/method.md §6).

For a fixed underlying linear model the NSI reconstruction is affine in the coefficients,
``ŷ(λ) = ŷ₀ + G λ`` (docs/method.md §6), so the residual of channel ``j`` is

.. math:: r_j(λ) = r_{0,j} - G_j λ = Z_j β,  \\qquad  Z_j = [r_j(c), G_j],\\; β = [1, -(λ - c)]

with ``c`` a reference point (the NSI estimate by default, which keeps the quadratic forms
well conditioned). Every Gaussian likelihood below is a function of the quadratic forms
``βᵀ W β`` of a few ``(q+1, q+1)`` Gram matrices ``W`` built once, in one O(N q² p) pass over
the samples; a likelihood evaluation then costs O(l p² q²) whatever N.

Noise models (per channel ``j``, innovation standard deviation ``σ_j``):

* white: ``e_t ~ N(0, σ²)``;
* AR(1), exact (stationary, Prais-Winsten form): ``e_t = ρ e_{t-1} + ε_t``;
* AR(p), conditional on the first ``p`` samples: ``e_t = Σ_i φ_i e_{t-i} + ε_t``.

The paper's plain ranking (Eqs. 1-4) uses the white model at ``σ̂² = RSS/n``:
:func:`plain_log_likelihood`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError, ShapeError

__all__ = [
    "SufficientStatistics",
    "sufficient_statistics",
    "log_likelihood_white",
    "log_likelihood_ar",
    "plain_log_likelihood",
]

_CHUNK_ELEMENTS = 2_000_000  # samples x channels x (q+1) per chunk: about 16 MB of float64
_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class SufficientStatistics:
    """Lagged Gram matrices of ``Z_j = [r_j(c), G_j]`` for every output channel.

    Attributes
    ----------
    lagged : ndarray, shape (l, p+1, q+1, q+1)
        ``C_{j,k} = Σ_{t=k}^{N-1} Z_{j,t}ᵀ Z_{j,t-k}`` for lags ``k = 0..p`` (``C_{j,0}`` is the
        lag-0 Gram ``Z_jᵀ Z_j``). Row/column 0 belongs to the residual at ``center``, rows
        ``1..q`` to the signatures ``g_i``.
    head : ndarray, shape (l, p, q+1)
        First ``p`` rows of ``Z_j`` (boundary terms of the AR likelihoods).
    tail : ndarray, shape (l, p, q+1)
        Last ``p`` rows of ``Z_j``.
    center : ndarray, shape (q,)
        Reference coefficients ``c`` at which the residual column was formed.
    n_samples : int
        ``N``, samples per channel.
    ar_order : int
        ``p``; 0 means white-noise statistics only.
    measured_std : ndarray, shape (l,)
        Standard deviation of each measured channel (default noise-prior range, docs/method.md §6).
    names : tuple of str
        Coefficient (term) names, length ``q``.
    """

    lagged: np.ndarray
    head: np.ndarray
    tail: np.ndarray
    center: np.ndarray
    n_samples: int
    ar_order: int
    measured_std: np.ndarray
    names: tuple[str, ...]

    @property
    def n_channels(self) -> int:
        """Number of output channels ``l``."""
        return int(self.lagged.shape[0])

    @property
    def n_coefficients(self) -> int:
        """Number of coefficients ``q``."""
        return int(self.lagged.shape[-1] - 1)

    @property
    def gram(self) -> np.ndarray:
        """Lag-0 Gram ``Z_jᵀ Z_j``, shape (l, q+1, q+1)."""
        return self.lagged[:, 0]

    def window_gram(self, order: int | None = None, method: str = "conditional") -> np.ndarray:
        """Gram matrices ``W_{j,ik}`` such that ``S_j = Σ_ik a_i a_k βᵀ W_{j,ik} β``.

        ``a = (1, -φ_1, ..., -φ_p)`` are the AR filter taps and ``S_j`` the innovation sum of
        squares of channel ``j`` (see Notes).

        Parameters
        ----------
        order : int, optional
            AR order ``p`` (default ``self.ar_order``); must not exceed ``self.ar_order``.
        method : {"conditional", "exact"}
            ``"conditional"``: sum over ``t = p..N-1`` (conditional AR(p) likelihood).
            ``"exact"``: stationary AR(1) (Prais-Winsten), only for ``order == 1``.

        Returns
        -------
        ndarray, shape (l, p+1, p+1, q+1, q+1)
            Symmetric in ``(i, k)`` with ``W_{ki} = W_{ik}ᵀ``.

        Notes
        -----
        Conditional: ``W_{ik} = Σ_{t=p}^{N-1} Z_{t-i}ᵀ Z_{t-k}``, obtained from the full lag
        sums ``C_{k-i}`` minus the products that fall in the first or last ``p`` samples.
        Exact AR(1): ``S = (1-ρ²) e_0² + Σ_{t≥1} (e_t - ρ e_{t-1})²
        = (1+ρ²) A_0 - 2ρ A_1 - ρ² (e_0² + e_{N-1}²)``, i.e. ``W_00 = C_0``,
        ``W_01 = C_1``, ``W_11 = C_0 - z_0 z_0ᵀ - z_{N-1} z_{N-1}ᵀ``.
        """
        p = self.ar_order if order is None else int(order)
        if p > self.ar_order:
            raise InputDataError(
                f"AR order {p} needs lagged statistics up to lag {p}; these hold up to lag {self.ar_order}. "
                f"Rebuild them with sufficient_statistics(affine, ar_order={p})."
            )
        l, m = self.n_channels, self.n_coefficients + 1
        out = np.empty((l, p + 1, p + 1, m, m))
        if method == "exact":
            if p != 1:
                raise InputDataError(f"the exact (stationary) AR likelihood is implemented for order 1, got {p}")
            c0, c1 = self.lagged[:, 0], self.lagged[:, 1]
            first, last = self.head[:, 0], self.tail[:, -1]
            out[:, 0, 0] = c0
            out[:, 0, 1] = c1
            out[:, 1, 0] = np.swapaxes(c1, -1, -2)
            out[:, 1, 1] = c0 - first[:, :, None] * first[:, None, :] - last[:, :, None] * last[:, None, :]
            return out
        if method != "conditional":
            raise InputDataError(f"method must be 'conditional' or 'exact', got {method!r}")
        n = self.n_samples
        head, tail = self.head, self.tail  # rows 0..P-1 and N-P..N-1 (P = self.ar_order)
        big_p = self.ar_order
        for i in range(p + 1):
            for k in range(i, p + 1):
                d = k - i
                w = self.lagged[:, d].copy()
                # products Z_s^T Z_{s-d} with s < p - i (start) ...
                for s in range(d, p - i):
                    w -= head[:, s, :, None] * head[:, s - d, None, :]
                # ... and with s >= N - i (end)
                for s in range(n - i, n):
                    a = tail[:, s - (n - big_p)]
                    b = tail[:, s - d - (n - big_p)]
                    w -= a[:, :, None] * b[:, None, :]
                out[:, i, k] = w
                out[:, k, i] = np.swapaxes(w, -1, -2)
        return out


def sufficient_statistics(
    affine, ar_order: int = 0, center=None, chunk_size: int | None = None
) -> SufficientStatistics:
    """Sufficient statistics of the Gaussian likelihood of an affine reconstruction (docs/method.md §6).

    Parameters
    ----------
    affine : AffineReconstruction
        ``measured`` (N, l), ``baseline`` (N, l), ``signatures`` (N, l, q), ``estimate`` (q,),
        ``names`` (q,), from :func:`bayesnsi.nsi.affine_reconstruction`.
    ar_order : int, default 0
        Largest residual AR order the statistics must support (0: white noise only).
    center : array_like, shape (q,), optional
        Reference coefficients ``c`` for the residual column (default ``affine.estimate``).
        Any value gives the same likelihood; one near the fit avoids cancellation.
    chunk_size : int, optional
        Samples per chunk (default: about 16 MB of working memory).

    Returns
    -------
    SufficientStatistics

    Raises
    ------
    ShapeError
        When the arrays of ``affine`` do not have the documented shapes.
    InputDataError
        On non-finite values, or fewer than ``2 ar_order + 2`` samples.

    Notes
    -----
    One pass over the samples, O(N l q² (p+1)) operations, memory O(chunk l q). Lag products
    across chunk borders use ``p`` rows of overlap. The input is not modified.
    """
    measured = np.asarray(affine.measured, dtype=float)
    baseline = np.asarray(affine.baseline, dtype=float)
    signatures = np.asarray(affine.signatures, dtype=float)
    if measured.ndim != 2:
        raise ShapeError(f"affine.measured must be (n_samples, n_channels), found shape {measured.shape}")
    n, l = measured.shape
    if baseline.shape != (n, l):
        raise ShapeError(f"affine.baseline must have the shape of measured {(n, l)}, found {baseline.shape}")
    if signatures.ndim != 3 or signatures.shape[:2] != (n, l):
        raise ShapeError(
            f"affine.signatures must be (n_samples, n_channels, q) = ({n}, {l}, q), found {signatures.shape}"
        )
    q = signatures.shape[2]
    names = tuple(str(s) for s in affine.names)
    if len(names) != q:
        raise ShapeError(f"affine.names has {len(names)} entries for {q} signature columns")
    p = int(ar_order)
    if p < 0:
        raise InputDataError(f"ar_order must be >= 0, got {ar_order}")
    if n < 2 * p + 2:
        raise InputDataError(f"need at least {2 * p + 2} samples for AR order {p}, got {n}")
    c = np.asarray(affine.estimate if center is None else center, dtype=float).reshape(-1)
    if c.shape != (q,):
        raise ShapeError(f"center must have shape ({q},), found {c.shape}")
    if not (np.all(np.isfinite(c))):
        raise InputDataError("center (coefficient estimate) holds NaN or Inf")

    if chunk_size is None:
        chunk_size = max(256, _CHUNK_ELEMENTS // max(1, l * (q + 1)))
    chunk_size = max(int(chunk_size), p + 1)
    lagged = np.zeros((l, p + 1, q + 1, q + 1))
    head = np.empty((l, p, q + 1))
    tail = np.empty((l, p, q + 1))

    def block(start: int, stop: int) -> np.ndarray:
        """``Z`` for samples ``start..stop-1``, laid out (l, samples, q+1)."""
        z = np.empty((l, stop - start, q + 1))
        y = measured[start:stop]
        z[:, :, 0] = (y - baseline[start:stop] - signatures[start:stop] @ c).T
        z[:, :, 1:] = signatures[start:stop].transpose(1, 0, 2)
        return z

    for start in range(0, n, chunk_size):
        stop = min(start + chunk_size, n)
        lo = max(0, start - p)
        z = block(lo, stop)
        if not np.all(np.isfinite(z)):
            raise InputDataError(f"the affine reconstruction holds NaN or Inf between samples {lo} and {stop}")
        off = start - lo
        for k in range(p + 1):
            s0 = max(off, k)
            cur = z[:, s0:]
            prev = z[:, s0 - k : z.shape[1] - k]
            lagged[:, k] += np.swapaxes(cur, 1, 2) @ prev
        if p and start == 0:
            head[:] = z[:, :p]
    if p:
        tail[:] = block(n - p, n)
    measured_std = measured.std(axis=0)
    return SufficientStatistics(
        lagged=lagged,
        head=head,
        tail=tail,
        center=c.copy(),
        n_samples=int(n),
        ar_order=p,
        measured_std=measured_std,
        names=names,
    )


def log_likelihood_white(lam, sigma, stats: SufficientStatistics) -> np.ndarray:
    """Gaussian white-noise log-likelihood of the coefficients (docs/method.md §6, paper Eq. 3).

    Parameters
    ----------
    lam : array_like, shape (..., q)
        Coefficients λ; leading dimensions are evaluated at once (vectorised).
    sigma : array_like, shape (..., l) or broadcastable (e.g. (..., 1) for a shared σ)
        Noise standard deviation per channel, in the output's units.
    stats : SufficientStatistics

    Returns
    -------
    ndarray, shape (...)
        ``Σ_j [-(N/2) log(2π σ_j²) - S_j(λ) / (2σ_j²)]`` with ``S_j(λ) = ‖r_j(λ)‖²``.
        Cost per parameter vector O(l q²), independent of N.
    """
    delta, batch = _delta(lam, stats)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), batch + (stats.n_channels,))
    ss = _quad(delta, stats.gram)
    n = stats.n_samples
    return np.sum(-0.5 * n * (_LOG_2PI + 2.0 * np.log(sigma)) - 0.5 * ss / sigma**2, axis=-1)


def log_likelihood_ar(lam, sigma, rho, stats: SufficientStatistics, method: str | None = None) -> np.ndarray:
    """Gaussian log-likelihood with AR(p) residuals, from sufficient statistics (docs/method.md §6).

    Parameters
    ----------
    lam : array_like, shape (..., q)
        Coefficients λ (leading dimensions vectorised).
    sigma : array_like, shape (..., l) or broadcastable
        Innovation standard deviation ``σ_j`` per channel.
    rho : array_like, shape (..., l) for AR(1), or (..., l, p) for AR(p)
        AR coefficients ``φ_{j,1..p}`` per channel; a shape (..., 1) or (..., 1, p) array (or a
        scalar) shares them across channels by broadcasting. The layout is told apart by the
        number of dimensions relative to ``lam``.
    stats : SufficientStatistics
        Built with ``ar_order >= p``.
    method : {"exact", "conditional"}, optional
        ``"exact"`` (default for p = 1): stationary AR(1), all N samples;
        ``"conditional"`` (default, and only choice, for p > 1): conditional on the first p.

    Returns
    -------
    ndarray, shape (...)

    Notes
    -----
    Exact AR(1), per channel (Prais-Winsten):
    ``ℓ = -(N/2) log(2πσ²) + ½ log(1-ρ²) - S/(2σ²)``,
    ``S = (1-ρ²) e_0² + Σ_{t=1}^{N-1} (e_t - ρ e_{t-1})²``, equal to the dense Gaussian with
    Toeplitz covariance ``σ² ρ^{|t-s|} / (1-ρ²)``. Values with ``|ρ| ≥ 1`` give ``-inf``.
    Conditional AR(p): ``ℓ = -((N-p)/2) log(2πσ²) - Σ_{t=p}^{N-1} (e_t - Σ_i φ_i e_{t-i})²/(2σ²)``.
    """
    delta, batch = _delta(lam, stats)
    rho = np.asarray(rho, dtype=float)
    if rho.ndim <= len(batch) + 1:
        rho = rho[..., None]
    p = rho.shape[-1]
    rho = np.broadcast_to(rho, batch + (stats.n_channels, p))
    if method is None:
        method = "exact" if p == 1 else "conditional"
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), batch + (stats.n_channels,))
    return _ar_loglik(delta, np.log(sigma), rho, stats.window_gram(p, method), stats.n_samples, method)


def plain_log_likelihood(residual) -> float:
    """The paper's Gaussian log-likelihood at the ML noise level (Eq. 4, docs/method.md §6).

    Parameters
    ----------
    residual : array_like, shape (n_samples, l) or (n_samples,)
        Reconstruction residual ``y - ŷ``.

    Returns
    -------
    float
        ``Σ_j -(n/2)(log(2π σ̂_j²) + 1)`` with ``σ̂_j² = mean(r_j²)``; a channel with an exactly
        zero residual gives ``+inf``, as the formula implies.
    """
    r = np.asarray(residual, dtype=float)
    r = r.reshape(len(r), -1)
    if not np.all(np.isfinite(r)):
        raise InputDataError("the residual holds NaN or Inf")
    n = r.shape[0]
    var = np.mean(r**2, axis=0)
    with np.errstate(divide="ignore"):
        return float(np.sum(-0.5 * n * (np.log(2.0 * np.pi * var) + 1.0)))


# ---------------------------------------------------------------------------------------------
# private helpers shared with sampling and marginal


def _delta(lam, stats: SufficientStatistics):
    """``λ - c`` and the batch shape; validates the trailing dimension."""
    lam = np.asarray(lam, dtype=float)
    q = stats.n_coefficients
    if lam.shape[-1:] != (q,) and not (q == 0 and lam.shape[-1:] == (0,)):
        raise ShapeError(f"coefficients must have trailing dimension q = {q}, found shape {lam.shape}")
    return lam - stats.center, lam.shape[:-1]


def _beta(delta: np.ndarray) -> np.ndarray:
    """``β = [1, -δ]``, shape (..., q+1)."""
    one = np.ones(delta.shape[:-1] + (1,))
    return np.concatenate([one, -delta], axis=-1)


def _quad(delta: np.ndarray, gram: np.ndarray) -> np.ndarray:
    """``βᵀ W_j β`` for every channel: (..., l)."""
    beta = _beta(delta)
    return np.einsum("...a,jab,...b->...j", beta, gram, beta)


def _ar_loglik(delta, log_sigma, rho, window, n_samples, method):
    """Vectorised AR log-likelihood; ``rho`` (..., l, p), ``window`` (l, p+1, p+1, q+1, q+1)."""
    beta = _beta(delta)
    p = rho.shape[-1]
    taps = np.concatenate([np.ones(rho.shape[:-1] + (1,)), -rho], axis=-1)  # (..., l, p+1)
    forms = np.einsum("...a,jikab,...b->...jik", beta, window, beta)
    ss = np.einsum("...ji,...jik,...jk->...j", taps, forms, taps)
    if method == "exact":
        n_eff = n_samples
        with np.errstate(divide="ignore", invalid="ignore"):
            logdet = np.where(np.abs(rho[..., 0]) < 1.0, 0.5 * np.log1p(-np.minimum(rho[..., 0] ** 2, 1.0)), -np.inf)
    else:
        n_eff = n_samples - p
        logdet = 0.0
    out = -0.5 * n_eff * (_LOG_2PI + 2.0 * log_sigma) - 0.5 * ss * np.exp(-2.0 * log_sigma) + logdet
    return np.sum(out, axis=-1)
