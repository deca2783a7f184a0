"""emcee moves of the evidence samplers (private; imports emcee: load it only where a sampler runs).

:class:`IndependenceMove` is a Metropolis-Hastings move of :mod:`emcee` whose proposal does not
depend on the walker's position: a multivariate t fixed before sampling at the Laplace mode. Mixed
with emcee's differential-evolution moves it is the ``"mixed"`` move set of both estimators
(docs/method.md §6).
"""

from __future__ import annotations

import emcee
import numpy as np

from ..exceptions import InputDataError

MIXED_MOVES = {
    "balanced": (("independence", 0.5), ("differential evolution", 0.4), ("differential evolution snooker", 0.1)),
    "independence": (("independence", 0.9), ("stretch", 0.1)),
}
"""The ``"mixed"`` moves and their probabilities per step.

``"balanced"``: all parameters (the joint estimator), or the coefficients where the proposal misses
their posterior: DE moves carry much of the mixing. ``"independence"``: the coefficients alone (the
collapsed estimator) where the proposal fits them (acceptance 0.6-0.95 on the reference cases); the
stretch move (vectorised in emcee, where the DE moves loop over the walkers in Python) keeps a local
move in the mix at little cost on a wide ensemble.
"""


class IndependenceMove(emcee.moves.MHMove):
    """Independence Metropolis-Hastings move with a fixed multivariate-t proposal ``g``.

    Parameters
    ----------
    mode : array_like, shape (d,)
        Centre of the proposal (the Laplace mode).
    cov : array_like, shape (d, d)
        Laplace covariance; the proposal's scale matrix is ``inflate² cov``.
    df : float, default 5
        Degrees of freedom of the t (heavier tails than the posterior's).
    inflate : float, default 1.2
        Scale factor of the proposal.

    Notes
    -----
    Every walker proposes ``x' ~ g`` whatever its position; emcee accepts with probability
    ``min(1, p(x') g(x) / (p(x) g(x')))``: the move's factors are ``log g(x) - log g(x')``.
    The move counts its proposals and acceptances (:attr:`acceptance`).
    """

    def __init__(self, mode, cov, df: float = 5.0, inflate: float = 1.2):
        self.mode = np.asarray(mode, dtype=float)
        self.chol = inflate * np.linalg.cholesky(np.atleast_2d(cov))
        self._whiten = np.linalg.inv(self.chol).T  # rows x -> L⁻¹(x - mode) by one product per step
        self.df = float(df)
        self.inflate = float(inflate)
        self.n_proposed = 0
        self.n_accepted = 0
        super().__init__(self._proposal, ndim=self.mode.size)

    @property
    def acceptance(self) -> float:
        """Fraction of this move's proposals accepted so far (NaN before the first)."""
        return self.n_accepted / self.n_proposed if self.n_proposed else float("nan")

    def log_g(self, x) -> np.ndarray:
        """Unnormalised log density of the proposal at rows of ``x``."""
        y = (np.asarray(x, dtype=float) - self.mode) @ self._whiten
        return -0.5 * (self.df + self.mode.size) * np.log1p(np.sum(y**2, axis=-1) / self.df)

    def _proposal(self, coords, random):
        n, d = coords.shape
        z = random.randn(n, d) / np.sqrt(random.chisquare(self.df, size=(n, 1)) / self.df)
        new = self.mode + z @ self.chol.T
        return new, self.log_g(coords) - self.log_g(new)

    def propose(self, model, state):
        """emcee's Metropolis-Hastings step, counted."""
        state, accepted = super().propose(model, state)
        self.n_proposed += accepted.size
        self.n_accepted += int(np.sum(accepted))
        return state, accepted


def move_list(kind: str, mode, cov, mix: str = "balanced"):
    """emcee's ``moves`` argument for ``kind``, the moves' names and their weights.

    Parameters
    ----------
    kind : {"mixed", "stretch", "de"}
        ``"mixed"``: :class:`IndependenceMove` with emcee's moves as :data:`MIXED_MOVES` lists them for
        ``mix``; ``"stretch"``: emcee's default ``StretchMove``; ``"de"``: ``DEMove`` 0.8,
        ``DESnookerMove`` 0.2.
    mode, cov : array_like
        Centre and covariance of the independence proposal.
    mix : {"balanced", "independence"}
        Key of :data:`MIXED_MOVES`.

    Returns
    -------
    (list of (emcee.moves.Move, float), tuple of str, tuple of float)
    """
    plan: tuple[tuple[str, float], ...]
    if kind == "stretch":
        plan = (("stretch", 1.0),)
    elif kind == "de":
        plan = (("differential evolution", 0.8), ("differential evolution snooker", 0.2))
    elif kind == "mixed":
        plan = MIXED_MOVES[mix]
    else:
        raise InputDataError(f"moves must be 'mixed', 'stretch' or 'de', got {kind!r}")
    makers = {"independence": lambda: IndependenceMove(mode, cov), "stretch": emcee.moves.StretchMove,
              "differential evolution": emcee.moves.DEMove, "differential evolution snooker": emcee.moves.DESnookerMove}
    objects = [(makers[name](), weight) for name, weight in plan]
    names = tuple(_describe(move) if isinstance(move, IndependenceMove) else name
                  for (move, _), (name, _) in zip(objects, plan))
    return objects, names, tuple(float(weight) for _, weight in plan)


def _describe(move: IndependenceMove) -> str:
    return f"independence (multivariate t, {move.df:g} dof, {move.inflate:g} x Laplace scale)"
