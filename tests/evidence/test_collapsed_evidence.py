"""The collapsed evidence estimator: noise parameters integrated out, λ sampled.

References are independent of the collapsed formulas: the joint log posterior of
:class:`~bayesnsi.evidence._target.Target` integrated over (log σ, ρ) by brute-force Gauss-Legendre
quadrature at fixed λ; the closed-form evidence of the affine model (itself checked against brute
force in tests/evidence/test_evidence.py); and the joint emcee + bridge estimator the collapsed one replaced.
"""

import numpy as np
import pytest
from scipy.special import logsumexp

from bayesnsi.evidence import (
    ARPrior,
    CoefficientPrior,
    NoisePrior,
    Priors,
    closed_form_log_evidence,
    evidence_from_statistics,
    posterior_summary,
    sufficient_statistics,
)
from bayesnsi.evidence._target import Target
from bayesnsi.evidence.collapsed import CollapsedTarget
from tests._helpers.affine import make_affine, make_priors
from tests._helpers.cases import base_seed

QUICK = {"n_walkers": 32, "n_steps": 600, "n_burn": 100}


def _brute_force(target: Target, lam: np.ndarray, nodes: int = 400, rho_halfwidth: float = 0.2) -> float:
    """log ∫ exp(joint log posterior) over (log σ[, ρ]) of one channel at fixed λ, on a dense box."""
    q = target.q
    mode = target.find_mode(target.initial_theta(lam))[0]  # centres the box on the innovation level
    theta0 = np.concatenate([lam, mode[q:]])
    lo_u, hi_u = np.log(target.priors.noise.lower[0]), np.log(target.priors.noise.upper[0])
    x, w = np.polynomial.legendre.leggauss(nodes)
    centre = float(np.clip(theta0[q], lo_u, hi_u))  # the mode may lie beyond the prior's lower end
    u_lo, u_hi = max(lo_u, centre - 0.5), min(hi_u, centre + 0.5)
    u = 0.5 * (u_hi - u_lo) * x + 0.5 * (u_hi + u_lo)
    wu = 0.5 * (u_hi - u_lo) * w
    if not target.order:
        theta = np.tile(theta0, (nodes, 1))
        theta[:, q] = u
        return float(logsumexp(target.log_posterior(theta) + np.log(wu)))
    r_lo = max(target.priors.ar.lower, theta0[q + 1] - rho_halfwidth)
    r_hi = min(target.priors.ar.upper, theta0[q + 1] + rho_halfwidth)
    r = 0.5 * (r_hi - r_lo) * x + 0.5 * (r_hi + r_lo)
    wr = 0.5 * (r_hi - r_lo) * w
    theta = np.tile(theta0, (nodes, nodes, 1))
    theta[..., q] = u[:, None]
    theta[..., q + 1] = r[None, :]
    return float(logsumexp(target.log_posterior(theta) + np.log(wu)[:, None] + np.log(wr)[None, :]))


@pytest.mark.parametrize(
    ("likelihood", "rho", "noise_range"),
    [
        ("white", 0.0, (1e-4, 10.0)),
        ("ar1", 0.5, (1e-4, 10.0)),
        ("ar1", -0.7, (1e-4, 10.0)),
        ("ar1", 0.995, (1e-4, 10.0)),  # ρ̂ within 8 sd of the prior bound 0.9999: Gauss-Legendre branch
        ("white", 0.0, (0.9, 10.0)),  # σ̂ (0.5 of std) below the prior's lower end: the tail series
        ("ar1", 0.3, (0.9, 10.0)),  # σ held at that end widens ρ's posterior to sd ≈ 0.17: the box spans (-1, 1)
    ],
)
def test_noise_integral_equals_brute_force_quadrature(likelihood, rho, noise_range):
    rng = np.random.default_rng(base_seed() + 301)
    affine = make_affine(1000, 1, 2, rng, sigma=0.5, rho=rho, smooth=True)
    std = affine.measured.std(axis=0)
    priors = Priors(
        coefficients=CoefficientPrior(affine.names, np.full(2, 3.0)),
        noise=NoisePrior(noise_range[0] * std * 0.5, noise_range[1] * std),
        ar=ARPrior(),
    )
    stats = sufficient_statistics(affine, ar_order=1)
    target = Target.build(stats, priors, likelihood)
    collapsed = CollapsedTarget(target)
    for shift in (0.0, 0.02):
        lam = stats.center + shift
        reference = _brute_force(target, lam, rho_halfwidth=2.0 if noise_range[0] > 0.1 else 0.2)
        assert collapsed.log_posterior(lam[None])[0] == pytest.approx(reference, abs=1e-6)


@pytest.mark.parametrize(("likelihood", "n_channels", "rho"), [("white", 3, 0.0), ("ar1", 1, 0.9)])
def test_collapsed_posterior_integrates_to_the_closed_form(likelihood, n_channels, rho):
    """∫ p̃(λ) dλ by quadrature over λ (q = 1) equals the closed-form evidence."""
    rng = np.random.default_rng(base_seed() + 302)
    affine = make_affine(5000, n_channels, 1, rng, rho=rho, smooth=True)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=1)
    target = Target.build(stats, priors, likelihood)
    mode, _, hess, _ = target.find_mode(target.initial_theta())
    sd = float(np.sqrt(np.linalg.inv(-hess)[0, 0]))
    x, w = np.polynomial.legendre.leggauss(200)
    lam = mode[0] + 15 * sd * x
    value = logsumexp(CollapsedTarget(target).log_posterior(lam[:, None]) + np.log(15 * sd * w))
    assert value == pytest.approx(closed_form_log_evidence(stats, priors, likelihood), abs=1e-4)


@pytest.mark.parametrize("likelihood", ["white", "ar1"])
def test_collapsed_and_joint_estimators_agree(likelihood):
    """Two channels, AR(1) noise: the same log Z and the same posterior of λ, σ and ρ as the joint sampler."""
    rng = np.random.default_rng(base_seed() + 303)
    affine = make_affine(20_000, 2, 2, rng, rho=0.6, smooth=True)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=1)
    new = evidence_from_statistics(stats, priors, likelihood, rng=1, warn=False, **QUICK)
    old = evidence_from_statistics(stats, priors, likelihood, rng=1, warn=False, collapse=False, **QUICK)
    assert new.settings["estimator"] == "collapsed" and old.settings["estimator"] == "joint"
    assert abs(new.log_evidence - old.log_evidence) <= max(0.02, 4 * np.hypot(new.log_evidence_se, old.log_evidence_se))
    assert new.log_evidence_se <= old.log_evidence_se
    assert new.convergence.converged
    a, b = new.posterior.samples.reshape(-1, new.posterior.samples.shape[-1]), old.posterior.samples
    b = b.reshape(-1, b.shape[-1])
    np.testing.assert_allclose(a.mean(axis=0), b.mean(axis=0), atol=0.1 * b.std(axis=0).max() + 1e-12)
    np.testing.assert_allclose(a.std(axis=0), b.std(axis=0), rtol=0.1)
    assert list(new.summary.index) == list(old.summary.index)
    np.testing.assert_allclose(new.summary["mean"], old.summary["mean"], rtol=1e-3, atol=1e-3)


def test_linear_candidate_has_nothing_to_sample():
    """q = 0: the evidence is the closed form itself; σ and ρ are drawn independently."""
    rng = np.random.default_rng(base_seed() + 304)
    affine = make_affine(3000, 1, 0, rng, rho=0.4)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=1)
    result = evidence_from_statistics(stats, priors, "ar1", rng=2, warn=False, closed_form=True, **QUICK)
    assert result.log_evidence == pytest.approx(result.closed_form_log_evidence, abs=1e-6)
    assert result.log_evidence_se == 0.0 and result.convergence.converged
    assert result.summary.loc["rho[y0]", "mean"] == pytest.approx(0.4, abs=0.05)
    assert result.posterior.samples.shape == (32, 500, 2)


def test_emcee_samples_the_collapsed_posterior_with_any_moves():
    """moves = "de" (emcee's DE moves alone, the full run) gives the evidence of the default mixed moves."""
    rng = np.random.default_rng(base_seed() + 305)
    affine = make_affine(5000, 2, 2, rng, rho=0.3, smooth=True)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=1)
    de = evidence_from_statistics(stats, priors, "ar1", rng=3, warn=False, moves="de", **QUICK)
    chain = evidence_from_statistics(stats, priors, "ar1", rng=3, warn=False, **QUICK)
    assert de.sampler.name == chain.sampler.name == "emcee"
    assert de.sampler.moves == ("differential evolution", "differential evolution snooker")
    assert (de.sampler.n_walkers, de.sampler.n_steps, de.sampler.n_burn) == (32, 600, 100)
    assert chain.sampler.moves[0].startswith("independence") and chain.sampler.moves[1] == "stretch"
    assert chain.sampler.weights == (0.9, 0.1)
    # the independence move mixes well here: a wide ensemble, a shortened run, recorded as it ran
    assert chain.sampler.n_walkers == 128 and chain.sampler.n_steps < 600 and chain.sampler.n_burn == 25
    assert chain.posterior.samples.shape[:2] == (128, chain.sampler.n_steps - 25)
    assert chain.settings["sampler"] == chain.sampler.describe()
    assert chain.posterior.to_datatree()["posterior"].attrs["sampler"].startswith("emcee 3")
    assert chain.to_dict()["sampler"]["n_walkers"] == 128
    assert chain.settings["acceptance_mean"] > 0.5
    tolerance = max(0.01, 4 * np.hypot(de.log_evidence_se, chain.log_evidence_se))
    assert abs(de.log_evidence - chain.log_evidence) <= tolerance


def test_noise_below_the_prior_floor_draws_rho_like_the_joint_sampler():
    """σ̂ = 0.5 under a prior starting at 1.0: σ sits at the floor and ρ's posterior widens (sd ≈ 0.04 instead
    of 0.02); the collapsed draws (inverse CDF on a grid, the t proposal misses) match the joint emcee run.

    Both runs are Monte-Carlo estimates from 32 x 500 draws, so their posterior means and sds are compared
    within 4 Monte-Carlo standard errors of the difference, sqrt(mcse_new² + mcse_old²) (arviz's mcse of the
    mean and of the sd, which account for the chains' autocorrelation; the collapsed run's σ, ρ draws follow
    its coefficient chain, so their mcse comes from the same chains). σ's sd at the floor is 5.7e-4 with an
    mcse of 5e-5 in the joint run: a fixed 15 % bound on it was under 2 standard errors and failed on some
    BLAS kernels. The collapsed 6.6e-4 is the truncated Gamma(n/2)'s exponential tail at the floor
    (sd ≈ 6.7e-4 for σ̂ = 0.5, n = 2000); the joint run comes up to it slowly (6.15e-4 at 3000 steps)."""
    rng = np.random.default_rng(base_seed() + 306)
    affine = make_affine(2000, 1, 1, rng, sigma=0.5, rho=0.3, smooth=True)
    priors = Priors(coefficients=CoefficientPrior(affine.names, np.full(1, 3.0)),
                    noise=NoisePrior(np.ones(1), 10 * affine.measured.std(axis=0)), ar=ARPrior())
    stats = sufficient_statistics(affine, ar_order=1)
    new = evidence_from_statistics(stats, priors, "ar1", rng=1, warn=False, closed_form=False, **QUICK)
    old = evidence_from_statistics(stats, priors, "ar1", rng=1, warn=False, closed_form=False, collapse=False,
                                   **QUICK)
    assert abs(new.log_evidence - old.log_evidence) <= max(0.02, 4 * np.hypot(new.log_evidence_se, old.log_evidence_se))
    new_mc = posterior_summary(new.posterior.to_datatree())  # the collapsed summary leaves σ's, ρ's mcse out
    for row in ("rho[y0]", "sigma[y0]"):
        for stat in ("sd", "mean"):
            se = np.hypot(new_mc.loc[row, f"mcse_{stat}"], old.summary.loc[row, f"mcse_{stat}"])
            assert abs(new.summary.loc[row, stat] - old.summary.loc[row, stat]) <= 4 * se, (row, stat, se)
    assert new.summary.loc["rho[y0]", "sd"] > 0.03  # widened: sqrt((1 - ρ²) / n) = 0.021 with σ free


def test_rho_quadrature_over_many_draws_is_blockwise_and_small():
    """ρ̂ near the prior bound for every draw (integrated accelerations: the residual's ρ ≈ 1) sends every
    integral to the 64-node quadrature; over 1e5 draws x 3 channels it is done in blocks (at once it
    peaked at 1.3 GB in `select` of a 58 400-sample record), each block equal to the integrals one by one."""
    import tracemalloc

    rng = np.random.default_rng(base_seed() + 307)
    affine = make_affine(3000, 3, 2, rng, sigma=0.5, rho=0.995, smooth=True)
    target = Target.build(sufficient_statistics(affine, ar_order=1), make_priors(affine), "ar1")
    collapsed = CollapsedTarget(target)
    lam = target.stats.center + 1e-3 * rng.standard_normal((100_000, 2))
    tracemalloc.start()
    values = collapsed.log_posterior(lam)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 200e6  # 96 MB; 1.9 GB with the node arrays of every integral at once (154 MB each)
    for row in (0, 54_321, 99_999):
        assert values[row] == pytest.approx(collapsed.log_posterior(lam[row : row + 1])[0], abs=1e-9)


def test_independence_move_leaves_the_target_invariant():
    """emcee with the independence move alone, proposal off-centre and too wide, samples a known Gaussian.

    With the Hastings factor left out or of the wrong sign the draws would follow p·g^∓1 instead: means
    off by several standard errors.
    """
    import emcee

    from bayesnsi.evidence._moves import IndependenceMove

    mean, sd = np.array([0.3, -0.2]), np.array([1.0, 0.5])

    def log_p(x):
        return -0.5 * np.sum(((x - mean) / sd) ** 2, axis=-1)

    move = IndependenceMove(np.zeros(2), np.diag([2.0, 1.0]))
    sampler = emcee.EnsembleSampler(64, 2, log_p, vectorize=True, moves=[(move, 1.0)])
    start = np.random.default_rng(base_seed() + 306).normal(size=(64, 2))
    sampler.run_mcmc(emcee.State(start, random_state=np.random.RandomState(base_seed() + 307).get_state()), 600,
                     progress=False)
    draws = sampler.get_chain(discard=100, flat=True)
    assert 0.3 < move.acceptance < 0.95
    n_eff = draws.shape[0] / 3.0  # independence moves at this acceptance: autocorrelation time below 3
    np.testing.assert_allclose(draws.mean(axis=0), mean, atol=float(4 * sd.max() / np.sqrt(n_eff)))
    np.testing.assert_allclose(draws.std(axis=0), sd, rtol=0.05)
