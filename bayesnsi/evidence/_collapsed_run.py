"""Sampling of the collapsed posterior of the coefficients with emcee, and its summary (docs/method.md §6, Eq. 6.4).

:class:`~bayesnsi.evidence.collapsed.CollapsedTarget` gives ``log p(λ | y)`` up to a constant with
the noise parameters integrated out. emcee samples it (``EnsembleSampler(..., vectorize=True)``: one
call per step for all walkers) with the ``"mixed"`` moves of :func:`~bayesnsi.evidence._moves.move_list`:
mostly an independence Metropolis-Hastings move whose multivariate-t proposal (5 degrees of freedom,
1.2 x the Laplace covariance at the mode) is fixed before sampling, with emcee's stretch move
(:data:`~bayesnsi.evidence._moves.MIXED_MOVES`). emcee's cost is mostly per step, whatever the number
of walkers (one vectorised call), so the run is shortened where the independence move mixes well:
:data:`ENSEMBLE_WALKERS` walkers, a burn-in of :data:`SHORT_BURN` steps after which the independence
move's acceptance must be at least :data:`MIN_ACCEPTANCE`, and a run that stops once every
coefficient's effective sample size reaches :data:`TARGET_ESS` (and 50 autocorrelation times),
within ``n_steps``. Otherwise (and for the ``"stretch"`` and ``"de"`` moves) emcee runs
``n_walkers`` walkers for ``n_steps`` steps and discards ``n_burn`` (the ``"mixed"`` moves then
weighted as for the joint estimator: independence 0.5, DE 0.4, DE snooker 0.1). The run that
happened is recorded (:class:`~bayesnsi.evidence.SamplerRecord`). ``σ`` and ``ρ`` are then drawn
exactly given each draw of ``λ``.
"""

from __future__ import annotations

import numpy as np

from ._target import Target
from .collapsed import CollapsedTarget

MIN_ACCEPTANCE = 0.25
"""Acceptance of the independence move during the burn-in above which the run is shortened (module notes)."""
ENSEMBLE_WALKERS = 128
"""Walkers of the shortened run: emcee's cost is per step, so a wide ensemble reaches an ESS in fewer steps."""
SHORT_BURN = 25
"""Burn-in steps of the shortened run (the walkers start from the Laplace approximation)."""
TARGET_ESS = 12_000
"""Effective sample size of every coefficient at which the shortened run stops (bridge error ≈ 1e-4 nat)."""
FIRST_BLOCK = 130
"""Steps after the burn-in before the autocorrelation time is first estimated (and more than the walkers)."""


def sample_collapsed(target: Target, rng, n_walkers: int, n_steps: int, n_burn: int, start, moves: str = "mixed",
                     found=None):
    """Draws of ``λ`` from the collapsed posterior by emcee (module notes), then ``σ`` and ``ρ`` given each draw.

    Returns ``(PosteriorSamples, CollapsedTarget)``; the draws hold ``θ = (λ, log σ, ρ)`` as those of
    :func:`~bayesnsi.evidence.sample_posterior`, and ``log_posterior`` is the joint one at ``θ``. The
    autocorrelation time is estimated for ``λ``; ``σ`` and ``ρ``, drawn afresh given each ``λ``, get the
    largest of ``λ``'s (their chains move only with it). ``n_steps`` and ``n_burn`` are the longest run;
    the run that really happened is in ``posterior.sampler``.
    ``found``: what ``target.find_mode(target.initial_theta(start))`` returned, when the caller has it.
    """
    import emcee

    from .posterior import PosteriorSamples, SamplerRecord
    from .sampling import (
        _chain_settings,
        _initial_walkers,
        _inside_support,
        _laplace_covariance,
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
    if q:
        p0 = _initial_walkers(collapsed, mode[:q], cov[:q, :q], n_walkers, rng)  # type: ignore[arg-type]
        lam, acceptance, record = _run_emcee(collapsed, p0, mode[:q], cov[:q, :q], moves, n_steps, n_burn, seed, rng)
    else:  # nothing to sample: independent draws of the noise parameters
        lam = np.zeros((n_walkers, n_steps - n_burn, 0))
        acceptance = np.ones(n_walkers)
        from .._version import __version__

        record = SamplerRecord("exact draws", __version__, (), (), n_walkers, n_steps - n_burn, 0,
                               "noise parameters, independently given no coefficient")
    n_walkers, n_draws = lam.shape[:2]
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
        settings={"n_walkers": n_walkers, "n_steps": record.n_steps, "n_burn": record.n_burn, "seed": seed,
                  "emcee_version": emcee.__version__, "moves": moves, "sampler": record.describe()},
        sampler=record,
    )
    return posterior, collapsed


def _run_emcee(collapsed: CollapsedTarget, p0, mode, cov, moves: str, n_steps: int, n_burn: int, seed: int, rng):
    """emcee over the coefficients (module notes): chains (walker, draw, q) after burn-in, acceptance, SamplerRecord."""
    import emcee

    from .._interrupt import interrupt_after
    from ._moves import IndependenceMove, move_list
    from .posterior import SamplerRecord
    from .sampling import _initial_walkers

    n_walkers, q = p0.shape
    random_state = np.random.RandomState(seed).get_state()
    run = {"progress": False, "skip_initial_state_check": True}
    shortened = moves == "mixed" and n_burn >= SHORT_BURN and n_steps - n_burn >= FIRST_BLOCK
    with interrupt_after():
        if shortened:  # a wide ensemble and a short run, while the independence move mixes well
            wide = max(n_walkers, ENSEMBLE_WALKERS)
            start = np.concatenate([p0, _initial_walkers(collapsed, mode, cov, wide - n_walkers, rng)])  # type: ignore[arg-type]
            move_objects, move_names, move_weights = move_list(moves, mode, cov, "independence")
            sampler = emcee.EnsembleSampler(wide, q, collapsed.log_posterior, vectorize=True, moves=move_objects)
            state = sampler.run_mcmc(emcee.State(start, random_state=random_state), SHORT_BURN, **run)
            independence = next(m for m, _ in move_objects if isinstance(m, IndependenceMove))
            shortened = independence.acceptance >= MIN_ACCEPTANCE
            if shortened:
                # more draws than walkers: arviz reads (chain, draw) arrays the other way round otherwise
                burn, budget, done = SHORT_BURN, n_steps - SHORT_BURN, 0
                block = min(max(FIRST_BLOCK, wide + 2), budget)
                sampler.reset()
                while block > 0:
                    state = sampler.run_mcmc(state, block, **run)
                    done += block
                    tau = float(np.max(_integrated_time(np.swapaxes(sampler.get_chain(), 0, 1))[0]))
                    needed = int(np.ceil(max(50.0 * tau, TARGET_ESS * tau / wide)))
                    block = max(0, min(needed, budget) - done)
                lam = np.swapaxes(sampler.get_chain(), 0, 1)
            else:  # the proposal misses the posterior: the full run with the walkers asked for
                random_state = state.random_state
                p0 = state.coords[:n_walkers]
        if not shortened:
            move_objects, move_names, move_weights = move_list(moves, mode, cov, "balanced")
            sampler = emcee.EnsembleSampler(n_walkers, q, collapsed.log_posterior, vectorize=True, moves=move_objects)
            sampler.run_mcmc(emcee.State(p0, random_state=random_state), n_steps, **run)
            burn, done = n_burn, n_steps - n_burn
            lam = np.swapaxes(sampler.get_chain(discard=n_burn), 0, 1)  # (walker, draw, q)
    acceptance = np.asarray(sampler.acceptance_fraction, dtype=float)
    record = SamplerRecord("emcee", emcee.__version__, move_names, move_weights, int(lam.shape[0]), burn + done,
                           burn, "coefficients (noise parameters integrated out)")
    return lam, acceptance, record


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
