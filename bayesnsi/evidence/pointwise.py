"""Pointwise log-likelihood by record block, for leave-one-block-out checks (docs/method.md §6).

arviz's ``loo`` and ``compare`` need the log-likelihood of each observation at each posterior
draw. A structure's response samples are not exchangeable (each sample's residual is correlated
with its neighbours'), so the observations here are ``B`` contiguous blocks of the record: the
log-likelihood of block ``b`` at draw ``θ_s`` is the likelihood of :mod:`.likelihood` on that
block's samples alone. Each block keeps its own sufficient statistics (one more pass over the
record, ``B`` times the memory of one set), so evaluating all draws costs O(S B l q²) whatever
the record length. For the white likelihood the blocks' values sum to the record's exactly; for
AR(1) each block starts from the stationary distribution (the correlation across a block border
is dropped, a relative change of about one sample in ``N/B``).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..exceptions import InputDataError
from ._target import parse_likelihood
from .likelihood import SufficientStatistics, log_likelihood_ar, log_likelihood_white, sufficient_statistics
from .posterior import PosteriorSamples

__all__ = ["DEFAULT_BLOCKS", "BlockStatistics", "block_statistics", "pointwise_log_likelihood"]

DEFAULT_BLOCKS = 20
"""Blocks the record is cut into (fewer when a block would hold fewer than :data:`MIN_BLOCK_SAMPLES`)."""

MIN_BLOCK_SAMPLES = 50
"""Least samples per block."""


@dataclass(frozen=True)
class BlockStatistics:
    """Sufficient statistics of contiguous blocks of the record (module notes).

    Attributes
    ----------
    bounds : ndarray of int, shape (B, 2)
        Half-open sample range ``[start, stop)`` of each block.
    lagged : ndarray, shape (B, l, p+1, q+1, q+1)
        Each block's lagged Gram matrices (:class:`~bayesnsi.evidence.likelihood.SufficientStatistics`).
    head, tail : ndarray, shape (B, l, p, q+1)
        First and last ``p`` rows of each block's ``Z``.
    measured_std : ndarray, shape (B, l)
        Standard deviation of each channel in each block.
    center : ndarray, shape (q,)
        Reference coefficients of the residual column.
    names : tuple of str
        Coefficient names.
    """

    bounds: np.ndarray
    lagged: np.ndarray
    head: np.ndarray
    tail: np.ndarray
    measured_std: np.ndarray
    center: np.ndarray
    names: tuple[str, ...]

    @property
    def n_blocks(self) -> int:
        """``B``."""
        return int(self.bounds.shape[0])

    def block(self, index: int) -> SufficientStatistics:
        """The statistics of one block.

        Parameters
        ----------
        index : int

        Returns
        -------
        SufficientStatistics
        """
        start, stop = (int(b) for b in self.bounds[index])
        return SufficientStatistics(
            lagged=self.lagged[index], head=self.head[index], tail=self.tail[index], center=self.center,
            n_samples=stop - start, ar_order=self.lagged.shape[2] - 1, measured_std=self.measured_std[index],
            names=self.names,
        )


def block_statistics(affine, ar_order: int = 0, n_blocks: int = DEFAULT_BLOCKS, center=None) -> BlockStatistics:
    """Sufficient statistics of ``n_blocks`` contiguous blocks of an affine reconstruction.

    Parameters
    ----------
    affine : AffineReconstruction
        As for :func:`~bayesnsi.evidence.likelihood.sufficient_statistics`.
    ar_order : int
        Largest residual AR order the statistics must support.
    n_blocks : int
        Blocks wanted; fewer when a block would hold fewer than :data:`MIN_BLOCK_SAMPLES` samples
        (at least one).
    center : array_like, shape (q,), optional
        Reference coefficients (default ``affine.estimate``).

    Returns
    -------
    BlockStatistics

    Raises
    ------
    InputDataError
        For ``n_blocks < 1``, or blocks too short for the AR order.
    """
    if int(n_blocks) != n_blocks or n_blocks < 1:
        raise InputDataError(f"n_blocks must be a positive integer, got {n_blocks!r}")
    measured = np.asarray(affine.measured, dtype=float)
    n = measured.shape[0]
    count = int(max(1, min(n_blocks, n // MIN_BLOCK_SAMPLES)))
    edges = np.linspace(0, n, count + 1).round().astype(int)
    center = np.asarray(affine.estimate if center is None else center, dtype=float).reshape(-1)
    parts = []
    for start, stop in zip(edges[:-1], edges[1:]):
        piece = SimpleNamespace(
            measured=measured[start:stop], baseline=np.asarray(affine.baseline)[start:stop],
            signatures=np.asarray(affine.signatures)[start:stop], estimate=center, names=affine.names,
        )
        parts.append(sufficient_statistics(piece, ar_order=ar_order, center=center))
    return BlockStatistics(
        bounds=np.stack([edges[:-1], edges[1:]], axis=1),
        lagged=np.stack([p.lagged for p in parts]),
        head=np.stack([p.head for p in parts]),
        tail=np.stack([p.tail for p in parts]),
        measured_std=np.stack([p.measured_std for p in parts]),
        center=center.copy(),
        names=tuple(str(name) for name in affine.names),
    )


def pointwise_log_likelihood(posterior: PosteriorSamples, blocks: BlockStatistics) -> np.ndarray:
    """Log-likelihood of each block at each posterior draw (module notes).

    Parameters
    ----------
    posterior : PosteriorSamples
        The draws (coefficients, noise levels and AR coefficients of its likelihood).
    blocks : BlockStatistics
        Of the record the posterior was drawn from, with ``ar_order`` at least the likelihood's.

    Returns
    -------
    ndarray, shape (chain, draw, B)

    Raises
    ------
    InputDataError
        When the blocks do not support the likelihood's AR order or hold other coefficients.
    """
    order, method = parse_likelihood(posterior.likelihood)
    if blocks.lagged.shape[2] - 1 < order:
        raise InputDataError(f"block statistics of AR order {blocks.lagged.shape[2] - 1} cannot score likelihood "
                             f"{posterior.likelihood!r}")
    if tuple(blocks.names) != tuple(posterior.coefficient_names):
        raise InputDataError(f"block statistics for coefficients {list(blocks.names)} cannot score a posterior "
                             f"of {list(posterior.coefficient_names)}")
    lam, sigma, rho = posterior.coefficients, posterior.sigma, posterior.rho
    out = np.empty(lam.shape[:2] + (blocks.n_blocks,))
    for b in range(blocks.n_blocks):
        stats = blocks.block(b)
        if order == 0:
            out[..., b] = log_likelihood_white(lam, sigma, stats)
        else:
            out[..., b] = log_likelihood_ar(lam, sigma, rho, stats, method)
    return out
