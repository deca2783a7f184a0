"""Block Hankel products: correlation (Gram) route and LQ reference route (docs/method.md §3).

Both routes return the lower-triangular factor ``L`` of the normalised Gram matrix of the
stacked block Hankel matrix, ``L Lᵀ = H Hᵀ / j``, with rows ordered ``[U_f; U_p; Y_p; Y_f]``
(Van Overschee & De Moor's ordering: every projection the algorithm needs is then a
truncation of ``L``). Every quantity of the subspace algorithm is a row-space operation on
``H``; such operations are invariant under ``H -> H Q`` with ``Q`` orthonormal, so they can be
carried out on ``L`` (Van Overschee & De Moor 1996, sec. 6.1: the "R factor" of the LQ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .._limits import DEFAULT_RUN_MEMORY, check_allocation

__all__ = [
    "ScaledStack",
    "extend_lagged_products",
    "grouped_order",
    "gram_factor",
    "hankel_gram",
    "lagged_products",
    "lq_factor", "HankelCorrelations", "correlation_key"
]

_CHUNK = 4096
_FFT_MIN_LAGS = 16  # from here on lagged_products by block FFTs (faster, same to rounding)
_FFT_BLOCK = 128


def grouped_order(block_rows: int, n_inputs: int, n_outputs: int) -> np.ndarray:
    """Permutation from the interleaved Hankel layout to the grouped one.

    Interleaved: block row r holds ``z_r = [u_r; y_r]`` (k = m + l channels). Grouped:
    ``[U_f; U_p; Y_p; Y_f]`` = ``[U_{i|2i-1}; U_{0|i-1}; Y_{0|2i-1}]``. Returns ``perm`` with
    ``grouped = interleaved[perm]``.
    """
    k = n_inputs + n_outputs
    blocks = np.arange(2 * block_rows)[:, None] * k
    u_rows = (blocks + np.arange(n_inputs)).reshape(2, -1)
    y_rows = (blocks + n_inputs + np.arange(n_outputs)).ravel()
    return np.concatenate([u_rows[1], u_rows[0], y_rows])


class ScaledStack:
    """``z = [u / u_scale, y / y_scale]`` built a few rows at a time (no copy of the record).

    Parameters
    ----------
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, l)
    u_scale, y_scale : ndarray, shapes (m,), (l,)
    """

    def __init__(self, u, y, u_scale=None, y_scale=None):
        self.u, self.y = u, y
        self.u_scale = np.ones(u.shape[1]) if u_scale is None else u_scale
        self.y_scale = np.ones(y.shape[1]) if y_scale is None else y_scale
        self.shape = (u.shape[0], u.shape[1] + y.shape[1])

    def rows(self, start: int, stop: int) -> np.ndarray:
        """Rows ``start:stop`` of z, zero beyond the record's end."""
        n, k = self.shape
        out = np.zeros((stop - start, k))
        last = min(stop, n)
        if last > start:
            m = self.u.shape[1]
            out[: last - start, :m] = self.u[start:last] / self.u_scale
            out[: last - start, m:] = self.y[start:last] / self.y_scale
        return out


def _as_stack(z) -> ScaledStack:
    if isinstance(z, ScaledStack):
        return z
    z = np.asarray(z, dtype=float)
    return ScaledStack(z, np.zeros((len(z), 0)))


def lagged_products(z, n_lags: int) -> np.ndarray:
    """``T_d = Σ_{t<j} z_t z_{t+d}ᵀ`` for ``d < n_lags``, ``j = N - n_lags + 1``; shape (n_lags, k, k).

    One pass over the data in chunks, memory independent of N. From 16 lags on by block FFTs
    (:func:`_lagged_products_fft`: O(k² N + k N log n_lags) flops, 4-12x faster at 40-80 lags),
    else directly (O(n_lags k² N)).
    """
    if n_lags >= _FFT_MIN_LAGS:
        return _lagged_products_fft(_as_stack(z), n_lags)
    stack = _as_stack(z)
    n, k = stack.shape
    j = n - n_lags + 1
    base = np.zeros((k, n_lags * k))
    for start in range(0, j, _CHUNK):
        stop = min(start + _CHUNK, j)
        chunk = stack.rows(start, stop + n_lags - 1)
        block = sliding_window_view(chunk, (n_lags, k))[:, 0].reshape(stop - start, n_lags * k)
        base += chunk[: stop - start].T @ block
    return base.reshape(k, n_lags, k).transpose(1, 0, 2)


def _lagged_products_fft(stack: ScaledStack, n_lags: int) -> np.ndarray:
    """:func:`lagged_products` by FFT cross-correlation of blocks of ``B = max(n_lags, 128)`` samples.

    Block b contributes ``Σ_{s<B} x_b[s] y_b[s + d]`` with ``x_b`` its own samples (those with
    t < j) and ``y_b`` the ``B + n_lags`` samples from its start; with FFTs of length
    ``B + n_lags`` the circular correlation equals that sum for every ``d < n_lags`` (no wrap).
    The cross-spectra are summed over the blocks and transformed back once.
    """
    n, k = stack.shape
    j, lags = n - n_lags + 1, n_lags
    size = max(lags, _FFT_BLOCK)
    n_fft = size + lags
    n_blocks, per_chunk = -(-j // size), max(1, _CHUNK // size)
    spectra = np.zeros((n_fft // 2 + 1, k, k), dtype=complex)
    for b0 in range(0, n_blocks, per_chunk):
        b1 = min(b0 + per_chunk, n_blocks)
        start, stop = b0 * size, b1 * size
        blocks = stack.rows(start, stop + size).reshape(b1 - b0 + 1, size, k)
        own = blocks[:-1]
        if stop > j:  # only t < j starts a product
            own = own.copy()
            own.reshape(-1, k)[j - start :] = 0.0
        fx = np.fft.rfft(own, n=n_fft, axis=1)
        fy = np.fft.rfft(np.concatenate([blocks[:-1], blocks[1:, :lags]], axis=1), axis=1)
        spectra += np.conj(fx).transpose(1, 2, 0) @ fy.transpose(1, 0, 2)
    return np.fft.irfft(spectra, n=n_fft, axis=0)[:lags]


def extend_lagged_products(lagged: np.ndarray, z, old_channels: np.ndarray) -> np.ndarray:
    """Lagged products of ``z`` from those of a subset of its channels (O(n_lags k N) per new channel).

    Parameters
    ----------
    lagged : ndarray, shape (n_lags, k0, k0)
        :func:`lagged_products` of the channels ``old_channels`` of ``z`` (same scaling).
    z : ndarray, shape (N, k), or ScaledStack
    old_channels : ndarray of int, shape (k0,)
        Where the old channels sit among the k channels of ``z``.

    Returns
    -------
    ndarray, shape (n_lags, k, k)
        Equal to ``lagged_products(z, n_lags)``; only the products that involve a new channel
        are computed (the closing-the-loop search adds one effect at a time to a fixed model).
    """
    stack = _as_stack(z)
    n, k = stack.shape
    n_lags = lagged.shape[0]
    j = n - n_lags + 1
    new = np.setdiff1d(np.arange(k), old_channels)
    out = np.zeros((n_lags, k, k))
    out[np.ix_(np.arange(n_lags), old_channels, old_channels)] = lagged
    if not len(new):
        return out
    leading = np.zeros((n_lags, len(new), k))  # Σ_t z_t[new] z_{t+d}ᵀ
    trailing = np.zeros((n_lags, k, len(new)))  # Σ_t z_t z_{t+d}[new]ᵀ
    for start in range(0, j, _CHUNK):
        stop = min(start + _CHUNK, j)
        size = stop - start
        chunk = stack.rows(start, stop + n_lags - 1)
        head = np.ascontiguousarray(chunk[:size, new])
        body = chunk[:size]
        for d in range(n_lags):
            lagged_rows = chunk[d : d + size]
            leading[d] += head.T @ lagged_rows
            trailing[d] += body.T @ lagged_rows[:, new]
    out[:, new, :] = leading
    out[:, :, new] = trailing
    return out


def hankel_gram(z, block_rows: int, lagged: np.ndarray | None = None) -> np.ndarray:
    """Gram matrix of the interleaved block Hankel matrix from lagged correlations.

    Parameters
    ----------
    z : ndarray, shape (n_samples, k), or ScaledStack
        Stacked signals ``[u, y]``.
    block_rows : int
        i; the Hankel matrix has 2i block rows and ``j = n_samples - 2i + 1`` columns.
    lagged : ndarray, shape (2i, k, k), optional
        :func:`lagged_products` of ``z`` when already computed.

    Returns
    -------
    ndarray, shape (2ik, 2ik)
        ``Σ_t h_t h_tᵀ`` with ``h_t = [z_t; z_{t+1}; ...; z_{t+2i-1}]`` (not normalised).

    Notes
    -----
    One pass over the data in chunks computes ``T_d = Σ_{t<j} z_t z_{t+d}ᵀ`` for all lags
    ``d < 2i`` (:func:`lagged_products`; O(i k² N) flops, memory independent of N: the scaled
    rows are built chunk by chunk); block ``(r, r+d)`` of the Gram matrix then follows exactly from
    ``S_{r,d} = T_d + Σ_{s<r} (z_{s+j} z_{s+j+d}ᵀ - z_s z_{s+d}ᵀ)`` (O(i³ k²), vectorised).
    """
    stack = _as_stack(z)
    n, k = stack.shape
    two_i = 2 * block_rows
    j = n - two_i + 1
    check_allocation(  # the (2i, 2i, k, k) blocks, their corrections and the assembled matrix
        5 * 8 * (two_i * k) ** 2, f"the Hankel Gram matrix of block_rows = {block_rows} x {k} channels "
        "(lower block_rows)", default=DEFAULT_RUN_MEMORY,
    )
    base = lagged_products(stack, two_i) if lagged is None else lagged
    # Edge corrections for every (r, d) at once: S_{r,d} = T_d + Σ_{s<r} (tail_s,d - head_s,d).
    head_rows = stack.rows(0, 2 * two_i - 2)
    tail_rows = stack.rows(j, j + 2 * two_i - 2)
    head_lagged = sliding_window_view(head_rows, (two_i, k))[:, 0]  # [s, d] = z_{s+d}
    tail_lagged = sliding_window_view(tail_rows, (two_i, k))[:, 0]
    head = np.einsum("sa,sdb->sdab", head_rows[: two_i - 1], head_lagged[: two_i - 1])
    tail = np.einsum("sa,sdb->sdab", tail_rows[: two_i - 1], tail_lagged[: two_i - 1])
    corrections = np.concatenate([np.zeros((1, two_i, k, k)), np.cumsum(tail - head, axis=0)])
    blocks = base[None] + corrections  # blocks[r, d] = S_{r,d}
    r_idx, s_idx = np.meshgrid(np.arange(two_i), np.arange(two_i), indexing="ij")
    lower, lag = np.minimum(r_idx, s_idx), np.abs(s_idx - r_idx)
    full = blocks[lower, lag]  # (2i, 2i, k, k); block (r, s) for r <= s
    swap = r_idx > s_idx
    full[swap] = full[swap].transpose(0, 2, 1)
    return full.transpose(0, 2, 1, 3).reshape(two_i * k, two_i * k)


def gram_factor(z, block_rows: int, n_inputs: int, lagged: np.ndarray | None = None) -> np.ndarray:
    """Square-root factor of the grouped, normalised Hankel Gram matrix (fast route).

    Returns lower-triangular ``L`` with ``L Lᵀ = H Hᵀ / j``, rows ``[U_f; U_p; Y_p; Y_f]``.
    A tiny diagonal load (relative 1e-12, raised until Cholesky succeeds) guards against rows
    that are exactly dependent, e.g. an input that is a delayed copy of another. ``lagged``:
    :func:`lagged_products` of ``z`` with ``2i`` lags, when already computed.
    """
    n, k = z.shape
    j = n - 2 * block_rows + 1
    perm = grouped_order(block_rows, n_inputs, k - n_inputs)
    gram = hankel_gram(z, block_rows, lagged)[np.ix_(perm, perm)] / j
    scale = np.trace(gram) / len(gram)
    load = 0.0
    for exponent in range(-14, -5):
        try:
            return np.linalg.cholesky(gram + load * np.eye(len(gram)))
        except np.linalg.LinAlgError:
            load = scale * 10.0**exponent
    raise np.linalg.LinAlgError("Hankel Gram matrix is not positive definite even after regularisation")


def lq_factor(z: np.ndarray | ScaledStack, block_rows: int, n_inputs: int) -> np.ndarray:
    """Reference route: the L factor of the LQ decomposition of the explicit Hankel matrix.

    Memory and time grow with ``2i k × N``: for validating :func:`gram_factor` and small data.
    """
    n, k = z.shape
    two_i = 2 * block_rows
    j = n - two_i + 1
    check_allocation(3 * 8 * max(j, 0) * two_i * k, f"the explicit Hankel matrix of block_rows = {block_rows} x {k} "
                     f"channels x {max(j, 0)} columns (lower block_rows, or use the correlation route)",
                     default=DEFAULT_RUN_MEMORY)
    z = _as_stack(z).rows(0, z.shape[0])
    windows = sliding_window_view(z, (two_i, k))[:, 0].reshape(j, two_i * k)
    perm = grouped_order(block_rows, n_inputs, k - n_inputs)
    r: np.ndarray = np.linalg.qr(windows[:, perm] / np.sqrt(j), mode="r")  # type: ignore[assignment]
    return r.T


@dataclass(frozen=True)
class HankelCorrelations:
    """Lagged products of one candidate's scaled ``[u, y]``, reusable by candidates that add terms.

    Made by :func:`hankel_correlations`; passed to :func:`identify` (``correlations=``) for a
    candidate whose terms start with these, it saves the products among the shared channels:
    only those of the added terms' inputs are computed (:func:`extend_lagged_products`).
    The closing-the-loop search identifies one fixed model plus each effect in turn, so most of
    the products are shared (time saved: ``docs/measurements.md``).

    Attributes
    ----------
    term_names : tuple of str
    key : tuple
        ``(n_samples, block_rows, input_hold, velocity_method, upsample)`` they were built with.
    scales : ndarray, shape (k,)
        Channel scales of ``[u, y]``.
    lagged : ndarray, shape (2i, k, k)
    """

    term_names: tuple[str, ...]
    key: tuple
    scales: np.ndarray
    lagged: np.ndarray

    def extended(self, terms, key, stack) -> np.ndarray | None:
        """Lagged products of ``stack`` (the channels of ``terms``) or None when these do not apply.

        They apply when ``terms`` start with this candidate's terms, the settings ``key`` are
        the same and the shared channels have the same scales.

        Parameters
        ----------
        terms : sequence of Term
            The new candidate's terms.
        key : tuple
            Its settings (:func:`correlation_key`).
        stack : ScaledStack
            Its scaled ``[u, y]``.

        Returns
        -------
        ndarray, shape (2i, k, k), or None
        """
        n_old_terms = len(self.term_names)
        if key != self.key or tuple(t.name for t in terms[:n_old_terms]) != self.term_names:
            return None
        n_outputs = stack.y.shape[1]
        scales = np.concatenate([stack.u_scale, stack.y_scale])
        n_shared_inputs = len(self.scales) - n_outputs
        old = np.concatenate([np.arange(n_shared_inputs), len(scales) - n_outputs + np.arange(n_outputs)])
        if not np.array_equal(scales[old], self.scales):
            return None
        return extend_lagged_products(self.lagged, stack, old)


def correlation_key(n_samples, block_rows, input_hold, velocity_method, upsample, stiffness=0.0) -> tuple:
    """Settings that must agree for :class:`HankelCorrelations` to be reused.

    Parameters
    ----------
    n_samples, block_rows : int
        Record length on the identification grid and i.
    input_hold, velocity_method : str
        Resolved input hold and differentiator.
    upsample : int
        Identification-grid factor.
    stiffness : float
        Virtual stiffness on the input (free bodies).

    Returns
    -------
    tuple
    """
    return (int(n_samples), int(block_rows), input_hold, velocity_method, int(upsample), float(stiffness))
