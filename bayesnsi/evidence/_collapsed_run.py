"""Sampling of the collapsed posterior of the coefficients, and its summary (docs/method.md §6, Eq. 6.4).

:class:`~bayesnsi.evidence.collapsed.CollapsedTarget` gives ``log p(λ | y)`` up to a constant with
the noise parameters integrated out. It is sampled by an independence Metropolis-Hastings chain per
walker whose proposal, a multivariate t (5 degrees of freedom) at the Laplace mode with 1.2 x its
covariance, is fixed before sampling; every proposal of every walker is evaluated in one vectorised
call, so the run costs milliseconds instead of emcee's per-step overhead (about 0.5 s for 1500 steps,
more than the 1 s budget of issue 15 allows for 16 channels with the residual). Where the proposal
does not fit the posterior (mean acceptance below 0.25: far from Gaussian, several modes), or when the
``stretch`` or ``de`` moves are asked for, emcee runs instead with the moves of
:func:`~bayesnsi.evidence.sample_posterior`. ``σ`` and ``ρ`` are then drawn exactly given each draw
of ``λ``.
"""

from __future__ import annotations

import numpy as np

from ._target import Target
from .collapsed import CollapsedTarget

MIN_ACCEPTANCE = 0.25
"""Mean acceptance of the independence chain below which emcee samples instead."""


def sample_collapsed(target: Target, rng, n_walkers: int, n_steps: int, n_burn: int, start, moves: str = "mixed",
                     found=None):
    """Draws of ``λ`` from the collapsed posterior (module notes), then ``σ`` and ``ρ`` given each draw.

    Returns ``(PosteriorSamples, CollapsedTarget)``; the draws hold ``θ = (λ, log σ, ρ)`` as those of
    :func:`~bayesnsi.evidence.sample_posterior`, and ``log_posterior`` is the joint one at ``θ``. The
    autocorrelation time is estimated for ``λ``; ``σ`` and ``ρ``, drawn afresh given each ``λ``, get the
    largest of ``λ``'s (their chains move only with it).
    ``found``: what ``target.find_mode(target.initial_theta(start))`` returned, when the caller has it.
    """
    import emcee

    from .._interrupt import interrupt_after
    from .sampling import (
        PosteriorSamples,
        _chain_settings,
        _initial_walkers,
        _inside_support,
        _laplace_covariance,
        _moves,
        check_chain_memory,
    )

    collapsed = CollapsedTarget(target)
    rng = np.random.default_rng(rng)
    q = target.q
    minimum = max(2 * q, 4)
    n_walkers, n_steps, n_burn = _chain_settings(n_walkers, n_steps, n_burn, minimum, f"2 x {q} coefficients (and 4)")
    check_chain_memory(n_walkers, n_steps, max(q, 1))
    theta0 = target.initial_theta(start)
    mode, _, hess, _ = found if found is not None else target.find_mode(theta0)
    mode = _inside_support(target, mode, theta0)
    cov = _laplace_covariance(hess, target, mode)
    seed = int(rng.integers(0, 2**32 - 1))
    n_draws = n_steps - n_burn
    sampler_name = "independence Metropolis-Hastings"
    if q:
        p0 = _initial_walkers(collapsed, mode[:q], cov[:q, :q], n_walkers, rng)  # type: ignore[arg-type]
        lam, acceptance = None, np.zeros(n_walkers)
        if moves == "mixed":
            lam, acceptance = _independence_chains(collapsed, p0, mode[:q], cov[:q, :q], n_steps, rng)
        if lam is None or float(np.mean(acceptance)) < MIN_ACCEPTANCE:
            sampler_name = f"emcee ({moves} moves)"
            sampler = emcee.EnsembleSampler(n_walkers, q, collapsed.log_posterior, vectorize=True,
                                            moves=_moves(moves, mode[:q], cov[:q, :q]))
            with interrupt_after():
                sampler.run_mcmc(emcee.State(p0, random_state=np.random.RandomState(seed).get_state()), n_steps,
                                 progress=False, skip_initial_state_check=True)
            lam = np.swapaxes(sampler.get_chain(), 0, 1)  # (walker, step, q)
            acceptance = np.asarray(sampler.acceptance_fraction, dtype=float)
        lam = lam[:, n_burn:]
    else:  # nothing to sample: independent draws of the noise parameters
        lam = np.zeros((n_walkers, n_draws, 0))
        acceptance = np.ones(n_walkers)
        sampler_name = "independent draws"
    flat = lam.reshape(n_walkers * n_draws, q)
    u, rho = collapsed.draw_noise(flat, rng)
    samples = np.concatenate([flat, u, rho.reshape(len(flat), -1)], axis=-1).reshape(n_walkers, n_draws, -1)
    # σ and ρ are drawn afresh given each λ: their chains move only with λ's, diluted by those draws
    if q:
        tau_lam, reliable = _integrated_time(lam)
        tau = np.concatenate([tau_lam, np.full(samples.shape[-1] - q, np.max(tau_lam))])
    else:  # independent draws
        tau, reliable = np.ones(samples.shape[-1]), True
    posterior = PosteriorSamples(
        samples=np.ascontiguousarray(samples),
        log_posterior=target.log_posterior(samples),
        param_names=target.param_names,
        coefficient_names=tuple(target.stats.names),
        channel_names=tuple(target.priors.noise.channel_names),
        likelihood=target.likelihood,
        ar_order=target.order,
        acceptance_fraction=acceptance,
        autocorr_time=tau,
        autocorr_reliable=reliable,
        mode=mode,
        mode_covariance=cov,
        settings={"n_walkers": n_walkers, "n_steps": n_steps, "n_burn": n_burn, "seed": seed,
                  "emcee_version": emcee.__version__, "moves": moves,
                  "sampler": f"collapsed: {sampler_name}"},
    )
    return posterior, collapsed


def _integrated_time(chains: np.ndarray, c: float = 5.0, tol: float = 50.0):
    """emcee's integrated autocorrelation time of (walker, draw, param) chains, all parameters at once.

    The estimator of :func:`emcee.autocorr.integrated_time` (walker-averaged normalised autocorrelation,
    Sokal's window with ``c = 5``), vectorised over walkers and parameters; ``reliable`` is False
    when the chain is shorter than ``tol`` autocorrelation times.
    """
    from scipy.fft import irfft, next_fast_len, rfft

    n_t = chains.shape[1]
    n_fft = next_fast_len(2 * n_t - 1, real=True)  # any length >= 2n-1 gives the same (linear) autocorrelation
    x = np.ascontiguousarray(np.moveaxis(chains, 1, -1))  # (walker, param, draw): transforms along rows
    x -= x.mean(axis=-1, keepdims=True)
    spectrum = rfft(x, n=n_fft, axis=-1)
    acf = irfft(spectrum.real**2 + spectrum.imag**2, n=n_fft, axis=-1)[..., :n_t]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.mean(acf / acf[..., :1], axis=0).T  # (draw, param)
    taus = 2.0 * np.cumsum(f, axis=0) - 1.0
    inside = np.arange(n_t)[:, None] < c * taus
    window = np.where(np.any(inside, axis=0), np.argmin(inside, axis=0), n_t - 1)
    tau = taus[window, np.arange(taus.shape[1])]
    return tau, bool(np.all(tol * tau <= n_t))


def _independence_chains(collapsed: CollapsedTarget, p0, mode, cov, n_steps: int, rng, df: float = 5.0,
                         inflate: float = 1.2):
    """Independence Metropolis-Hastings from ``p0`` (walker, q): chains (walker, step, q) and acceptance.

    The proposal is the multivariate t of :class:`~bayesnsi.evidence.sampling._IndependenceProposal`
    (the one emcee's mixed moves use half of the time); its draws do not depend on the state, so all
    are drawn and evaluated at once and only the accept/reject recursion runs step by step.
    """
    n_walkers, q = p0.shape
    chol = inflate * np.linalg.cholesky(cov)

    def log_g(z):
        return -0.5 * (df + q) * np.log1p(np.sum(z**2, axis=-1) / df)

    z = rng.standard_normal((n_steps, n_walkers, q)) / np.sqrt(rng.chisquare(df, size=(n_steps, n_walkers, 1)) / df)
    proposals = mode + z @ chol.T
    with np.errstate(invalid="ignore", over="ignore"):
        weight = collapsed.log_posterior(proposals.reshape(-1, q)).reshape(n_steps, n_walkers) - log_g(z)
        current = p0.copy()
        w_cur = collapsed.log_posterior(p0) - log_g(np.linalg.solve(chol, (p0 - mode).T).T)
    log_u = np.log(rng.uniform(size=(n_steps, n_walkers)))
    chain = np.empty((n_steps, n_walkers, q))
    accepted = np.zeros(n_walkers)
    for t in range(n_steps):
        take = log_u[t] < weight[t] - w_cur
        current = np.where(take[:, None], proposals[t], current)
        w_cur = np.where(take, weight[t], w_cur)
        accepted += take
        chain[t] = current
    return np.swapaxes(chain, 0, 1), accepted / n_steps


def collapsed_summary(posterior, rhat_threshold: float, ess_threshold: float, ci_prob: float = 0.95):
    """Summary table and convergence report of a collapsed run: ``(DataFrame, ConvergenceReport)``.

    The coefficients, the only parameters emcee sampled, get the arviz rows of
    :func:`~bayesnsi.evidence.posterior_summary` and decide convergence. ``σ`` and ``ρ`` are drawn
    exactly given each coefficient draw, so the chain's mixing is that of the coefficients: their
    rows hold mean, sd and HDI (arviz's narrowest-interval rule) and NaN for ESS, R-hat and MCSE.
    With no coefficient the draws are independent and the run counts as converged.
    """
    import pandas as pd

    from .convergence import ConvergenceReport, convergence_report, posterior_summary

    q = posterior.n_coefficients
    n_chains, n_draws = posterior.samples.shape[:2]
    perc = int(round(100 * ci_prob))
    columns = ["mean", "sd", f"hdi{perc}_lb", f"hdi{perc}_ub", "ess_bulk", "ess_tail", "r_hat", "mcse_mean", "mcse_sd"]
    frames = []
    if q:
        from arviz_base import from_dict

        tree = from_dict({"posterior": {"coefficient": posterior.coefficients}}, sample_dims=["chain", "draw"],
                         coords={"term": list(posterior.coefficient_names)}, dims={"coefficient": ["term"]})
        frames.append(posterior_summary(tree, ci_prob=ci_prob)[columns])
        report = convergence_report(frames[0], rhat_threshold, ess_threshold, n_chains=n_chains, n_draws=n_draws)
    else:
        total = float(n_chains * n_draws)
        report = ConvergenceReport(1.0, total, total, "", "", float(rhat_threshold), float(ess_threshold),
                                   int(n_chains), int(n_draws))
    names = [f"sigma[{c}]" for c in posterior.channel_names]
    parts = [posterior.sigma.reshape(-1, posterior.n_channels)]
    if posterior.ar_order:
        names += [f"rho[{c}]" for c in posterior.channel_names]
        parts.append(posterior.rho[..., 0].reshape(-1, posterior.n_channels))
    x = np.sort(np.concatenate(parts, axis=1).T, axis=1)  # one contiguous row per parameter
    inc = int(np.floor(ci_prob * x.shape[1]))
    start = np.argmin(x[:, inc:] - x[:, : x.shape[1] - inc], axis=1)
    rows = np.arange(x.shape[0])
    table = np.full((x.shape[0], len(columns)), np.nan)
    table[:, 0], table[:, 1] = x.mean(axis=1), x.std(axis=1)
    table[:, 2], table[:, 3] = x[rows, start], x[rows, start + inc]
    frames.append(pd.DataFrame(table, index=names, columns=columns))
    return pd.concat(frames), report
