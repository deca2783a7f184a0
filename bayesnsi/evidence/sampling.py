"""Posterior sampling of a candidate's coefficients and noise parameters with emcee (docs/method.md §6).

The unnormalised posterior ``π(θ) L(θ)`` of ``θ = (λ, log σ_1..log σ_l[, φ])`` is evaluated
from :class:`~bayesnsi.evidence.likelihood.SufficientStatistics` for all walkers at once
(``emcee.EnsembleSampler(..., vectorize=True)``), so a step costs microseconds whatever the
record length. The walkers start from the Gaussian (Laplace) approximation at the posterior
mode, which Newton's method reaches from the NSI estimate.

Array convention: posterior draws are ``(chain, draw, ...)`` with one chain per walker.
"""

from __future__ import annotations

import numpy as np

from .._interrupt import interrupt_after
from .._limits import DEFAULT_RUN_MEMORY, check_allocation
from ..exceptions import InputDataError
from ._target import Target
from .likelihood import SufficientStatistics
from .posterior import PosteriorSamples, SamplerRecord
from .priors import Priors

__all__ = ["chain_bytes", "check_chain_memory", "sample_posterior"]


def sample_posterior(
    stats: SufficientStatistics,
    priors: Priors,
    likelihood: str = "white",
    rng=None,
    n_walkers: int = 32,
    n_steps: int = 1500,
    n_burn: int = 300,
    start=None,
    moves: str = "mixed",
) -> PosteriorSamples:
    """Sample the posterior of ``(λ, log σ[, φ])`` with emcee (docs/method.md §6).

    Parameters
    ----------
    stats : SufficientStatistics
        From :func:`~bayesnsi.evidence.sufficient_statistics` (``ar_order`` at least the AR
        order of ``likelihood``).
    priors : Priors
        Proper priors fixed before the fit.
    likelihood : {"white", "ar1", "arP"}
        Residual model: white Gaussian; exact stationary AR(1); conditional AR(P).
    rng : int or numpy.random.Generator, optional
        Source of every random choice (walker start, emcee's moves via a seeded
        ``RandomState`` passed in ``emcee.State(random_state=...)``).
    n_walkers : int, default 32
        Number of walkers (= chains); at least ``2 n_params``.
    n_steps : int, default 1500
        Steps per walker, including burn-in.
    n_burn : int, default 300
        Steps discarded at the start.
    start : array_like, shape (q,), optional
        Coefficients from which the mode search starts (default: the NSI estimate,
        ``stats.center``).
    moves : {"mixed", "stretch", "de"}
        emcee moves. ``"mixed"`` (default): per step, with probabilities 0.5/0.4/0.1, an
        independence Metropolis-Hastings move with a fixed multivariate-t proposal (5 degrees of
        freedom, scale 1.2 x the Laplace covariance at the mode), emcee's ``DEMove`` and
        ``DESnookerMove``. ``"stretch"``: emcee's default ``StretchMove``; ``"de"``: DE moves
        only (0.8/0.2).

    Returns
    -------
    PosteriorSamples

    Notes
    -----
    ``log p(θ|y) = log N(λ; 0, diag s²) + Σ_j log U(log σ_j) [+ log U(φ)] + log L(θ) + const``;
    ``log L`` as in :func:`~bayesnsi.evidence.log_likelihood_white` /
    :func:`~bayesnsi.evidence.log_likelihood_ar` (paper Eq. 3 generalised to AR residuals).
    The walkers start from ``N(θ*, (-H)⁻¹)`` at the mode ``θ*`` restricted to the prior support,
    so little burn-in is needed.

    Because ``r_hat`` is computed with one chain per walker, reaching ``r_hat <= 1.01`` needs
    about 100 autocorrelation times per walker; the ``"mixed"`` moves have the shortest
    autocorrelation time (measurements in ``docs/measurements.md``). The independence move's
    proposal is fixed before sampling (from the mode), so every move is a valid
    Metropolis-Hastings kernel and their mixture leaves the posterior invariant.
    """
    target = Target.build(stats, priors, likelihood)
    return _sample(target, rng, n_walkers, n_steps, n_burn, start, moves)



def _chain_settings(n_walkers, n_steps, n_burn, minimum: int, what: str) -> tuple[int, int, int]:
    """``(n_walkers, n_steps, n_burn)`` as ints, checked: even walkers >= ``minimum``, 0 <= burn < steps."""
    n_walkers, n_steps, n_burn = int(n_walkers), int(n_steps), int(n_burn)
    if n_walkers < minimum or n_walkers % 2:
        raise InputDataError(f"n_walkers must be even and >= {what} = {minimum}, got {n_walkers}")
    if not 0 <= n_burn < n_steps:
        raise InputDataError(f"need 0 <= n_burn < n_steps, got n_burn = {n_burn}, n_steps = {n_steps}")
    return n_walkers, n_steps, n_burn

def chain_bytes(n_walkers: int, n_steps: int, ndim: int) -> int:
    """Peak memory [bytes] of one emcee run: its stored chain and log posterior, and their copies.

    emcee allocates the whole chain, ``n_steps x n_walkers x ndim``, and the log posterior,
    ``n_steps x n_walkers``, before the first step; the kept draws are copied once more into
    :class:`PosteriorSamples`, and the autocorrelation time works on a few rows of the same size.

    Parameters
    ----------
    n_walkers, n_steps, ndim : int
        Walkers, steps per walker, parameters.

    Returns
    -------
    int
        ``8 x n_steps x n_walkers x (2 (ndim + 1) + 4)``.

    Examples
    --------
    >>> chain_bytes(32, 1500, 4)
    5376000
    """
    return 8 * int(n_steps) * int(n_walkers) * (2 * (int(ndim) + 1) + 4)


def check_chain_memory(n_walkers: int, n_steps: int, ndim: int, what: str = "the sampler", runs: int = 1) -> None:
    """Refuse, before anything is allocated, a sampler whose chains would pass the memory limit.

    Parameters
    ----------
    n_walkers, n_steps, ndim : int
        Walkers, steps per walker, parameters (a lower bound is enough to refuse).
    what : str
        What runs, for the message.
    runs : int
        Samplers held at once (e.g. one per worker process).

    Raises
    ------
    InputDataError
        When ``runs x chain_bytes(...)`` exceeds :func:`bayesnsi._limits.max_memory_bytes` (default
        :data:`bayesnsi._limits.DEFAULT_RUN_MEMORY`); the message names n_walkers and n_steps.
    """
    check_allocation(
        int(runs) * chain_bytes(n_walkers, n_steps, ndim),
        f"{what} ([evidence] n_walkers = {int(n_walkers)} x n_steps = {int(n_steps)} x at least {int(ndim)} "
        "parameters; lower n_walkers or n_steps)",
        default=DEFAULT_RUN_MEMORY,
    )


def _sample(
    target: Target, rng, n_walkers: int, n_steps: int, n_burn: int, start, moves: str = "mixed"
) -> PosteriorSamples:
    """emcee run on a prepared target."""
    import emcee

    rng = np.random.default_rng(rng)
    ndim = target.ndim
    n_walkers, n_steps, n_burn = _chain_settings(n_walkers, n_steps, n_burn, 2 * ndim, f"2 x {ndim} parameters")
    check_chain_memory(n_walkers, n_steps, ndim)

    theta0 = target.initial_theta(start)
    mode, _, hess, _ = target.find_mode(theta0)
    mode = _inside_support(target, mode, theta0)
    cov = _laplace_covariance(hess, target, mode)
    p0 = _initial_walkers(target, mode, cov, n_walkers, rng)
    seed = int(rng.integers(0, 2**32 - 1))
    random_state = np.random.RandomState(seed).get_state()

    from ._moves import move_list

    move_objects, move_names, move_weights = move_list(moves, mode, cov, "balanced")
    sampler = emcee.EnsembleSampler(n_walkers, ndim, target.log_posterior, vectorize=True, moves=move_objects)
    with interrupt_after():
        sampler.run_mcmc(
            emcee.State(p0, random_state=random_state), n_steps, progress=False, skip_initial_state_check=True
        )
    chain = sampler.get_chain(discard=n_burn)  # (draw, walker, param)
    log_post = sampler.get_log_prob(discard=n_burn)  # (draw, walker)
    tau, reliable = _autocorr(chain)
    record = SamplerRecord("emcee", emcee.__version__, move_names, move_weights, n_walkers, n_steps, n_burn,
                           "all parameters")
    return PosteriorSamples(
        samples=np.ascontiguousarray(np.swapaxes(chain, 0, 1)),
        log_posterior=np.ascontiguousarray(log_post.T),
        param_names=target.param_names,
        coefficient_names=tuple(target.stats.names),
        channel_names=tuple(target.priors.noise.channel_names),
        likelihood=target.likelihood,
        ar_order=target.order,
        acceptance_fraction=np.asarray(sampler.acceptance_fraction, dtype=float),
        autocorr_time=tau,
        autocorr_reliable=reliable,
        mode=mode,
        mode_covariance=cov,
        settings={
            "n_walkers": n_walkers,
            "n_steps": n_steps,
            "n_burn": n_burn,
            "seed": seed,
            "emcee_version": emcee.__version__,
            "moves": moves,
            "sampler": record.describe(),
        },
        sampler=record,
    )


def _laplace_covariance(hess: np.ndarray, target: Target, mode: np.ndarray) -> np.ndarray:
    """``(-H)⁻¹``, or a diagonal fallback when ``-H`` is not positive definite."""
    neg = -0.5 * (hess + hess.T)
    try:
        np.linalg.cholesky(neg)
        cov = np.linalg.inv(neg)
        return 0.5 * (cov + cov.T)
    except np.linalg.LinAlgError:
        diag = np.abs(np.diag(neg))
        fallback = np.concatenate([target.priors.coefficients.scale**2, np.full(target.ndim - target.q, 1e-2)])
        return np.diag(np.where(diag > 0, 1.0 / np.where(diag > 0, diag, 1.0), fallback))


def _inside_support(target: Target, mode: np.ndarray, theta0: np.ndarray) -> np.ndarray:
    """Pull a mode that sits on the edge of the prior support (e.g. ρ at its bound) inside it."""
    for _ in range(60):
        if np.isfinite(target.log_posterior(mode[None])[0]):
            return mode
        mode = theta0 + 0.9 * (mode - theta0)
    return mode


def _initial_walkers(target: Target, mode, cov, n_walkers: int, rng) -> np.ndarray:
    """Draws from ``N(mode, cov)`` inside the prior support (redrawn, else shrunk towards the mode)."""
    ndim = target.ndim
    chol = np.linalg.cholesky(cov)
    p0 = mode + rng.standard_normal((n_walkers, ndim)) @ chol.T
    for _ in range(20):
        bad = ~np.isfinite(target.log_posterior(p0))
        if not np.any(bad):
            break
        p0[bad] = mode + rng.standard_normal((int(bad.sum()), ndim)) @ chol.T
    bad = ~np.isfinite(target.log_posterior(p0))
    if np.any(bad):  # mode at the edge of the support: stay close to it
        p0[bad] = mode + 1e-3 * (rng.standard_normal((int(bad.sum()), ndim)) @ chol.T)
    if not np.all(np.isfinite(target.log_posterior(p0))):
        raise InputDataError(
            "could not place the walkers inside the prior support near the posterior mode; the noise prior "
            f"spans {np.array2string(target.priors.noise.lower, precision=3)} to "
            f"{np.array2string(target.priors.noise.upper, precision=3)} (output units): check it against the "
            "residual, e.g. lower [evidence] noise_floor (a multiple of std(y))"
        )
    return p0


def _autocorr(chain: np.ndarray):
    """emcee's integrated autocorrelation time of a (draw, walker, param) chain."""
    from emcee.autocorr import AutocorrError, integrated_time

    try:
        return np.asarray(integrated_time(chain), dtype=float), True
    except AutocorrError as err:
        return np.asarray(err.tau, dtype=float), False
