"""Tests of bayesnsi.evidence (SPEC section 6).

Reference values are independent computations: the residual built sample by sample, a dense
Toeplitz Gaussian (scipy), brute-force quadrature over (λ, log σ), and the exact evidence of the
affine model. Stochastic tolerances are multiples of the reported Monte-Carlo error.
"""

import subprocess
import sys

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.linalg import toeplitz

from bayesnsi.evidence import (
    ARPrior,
    CoefficientPrior,
    NoisePrior,
    closed_form_log_evidence,
    coefficient_prior,
    compare_evidence,
    default_coefficient_scales,
    default_priors,
    evidence_from_statistics,
    laplace_log_evidence,
    log_likelihood_ar,
    log_likelihood_white,
    marginal_evidence,
    plain_log_likelihood,
    plain_ranking,
    posterior_probabilities,
    ranking_table,
    sample_posterior,
    sufficient_statistics,
)
from bayesnsi.exceptions import ConvergenceWarning, InputDataError, ShapeError
from bayesnsi.nsi import AffineReconstruction
from tests._helpers.affine import make_affine, make_priors
from tests._helpers.cases import base_seed

# tolerances, named by meaning
EXACT_REL = 1e-9  # sufficient statistics vs direct sums (floating point only)
EVIDENCE_NAT = 0.1  # SPEC/EVIDENCE: accept max(0.1 nat, 3 SE) against the exact value
LAPLACE_NAT = 0.1  # EVIDENCE.md: Laplace is a cross-check within 0.1 nat on these problems
QUICK = {"n_walkers": 32, "n_steps": 1000, "n_burn": 200}  # shorter runs keep the suite fast


def residuals(affine, lam):
    """``r(λ)`` for each row of ``lam``: shape (n_rows, N, l), built directly."""
    lam = np.atleast_2d(lam)
    return np.stack([affine.measured - affine.baseline - affine.signatures @ row for row in lam])


# ---------------------------------------------------------------------------------------------
# likelihood


@pytest.mark.parametrize("q", [1, 2, 4])
def test_white_likelihood_from_statistics_equals_direct(q):
    rng = np.random.default_rng(base_seed() + q)
    affine = make_affine(3000, 2, q, rng)
    st = sufficient_statistics(affine, chunk_size=257)  # several chunks
    lam = affine.estimate + 0.05 * rng.standard_normal((6, q))
    sigma = 0.5 * np.exp(0.2 * rng.standard_normal((6, 2)))
    r = residuals(affine, lam)
    n = affine.measured.shape[0]
    direct = np.sum(-0.5 * n * np.log(2 * np.pi * sigma**2) - 0.5 * np.sum(r**2, axis=1) / sigma**2, axis=1)
    np.testing.assert_allclose(log_likelihood_white(lam, sigma, st), direct, rtol=EXACT_REL)


def test_ar1_likelihood_equals_dense_toeplitz():
    rng = np.random.default_rng(base_seed() + 11)
    affine = make_affine(240, 2, 3, rng, rho=0.7)
    st = sufficient_statistics(affine, ar_order=1, chunk_size=50)
    lam = affine.estimate + 0.1 * rng.standard_normal((4, 3))
    sigma = 0.5 * np.exp(0.2 * rng.standard_normal((4, 2)))
    rho = rng.uniform(-0.95, 0.95, size=(4, 2))
    r = residuals(affine, lam)
    n = r.shape[1]
    dense = np.zeros(4)
    for w in range(4):
        for j in range(2):
            cov = sigma[w, j] ** 2 / (1 - rho[w, j] ** 2) * toeplitz(rho[w, j] ** np.arange(n))
            dense[w] += stats.multivariate_normal(np.zeros(n), cov).logpdf(r[w, :, j])
    np.testing.assert_allclose(log_likelihood_ar(lam, sigma, rho, st), dense, rtol=EXACT_REL)
    # a shared rho broadcasts over channels
    shared = log_likelihood_ar(lam, sigma, rho[:, :1], st)
    expected = log_likelihood_ar(lam, sigma, np.repeat(rho[:, :1], 2, axis=1), st)
    np.testing.assert_allclose(shared, expected, rtol=EXACT_REL)


def test_conditional_ar_likelihood_equals_direct():
    rng = np.random.default_rng(base_seed() + 12)
    affine = make_affine(500, 2, 2, rng, rho=0.5)
    st = sufficient_statistics(affine, ar_order=3, chunk_size=64)
    lam = affine.estimate + 0.1 * rng.standard_normal((3, 2))
    sigma = np.full((3, 2), 0.6)
    phi = rng.uniform(-0.4, 0.4, size=(3, 2, 3))
    r = residuals(affine, lam)
    expected = np.zeros(3)
    for w in range(3):
        for j in range(2):
            e = r[w, :, j]
            innov = e[3:] - phi[w, j, 0] * e[2:-1] - phi[w, j, 1] * e[1:-2] - phi[w, j, 2] * e[:-3]
            expected[w] += np.sum(stats.norm(0, sigma[w, j]).logpdf(innov))
    np.testing.assert_allclose(log_likelihood_ar(lam, sigma, phi, st), expected, rtol=EXACT_REL)


def test_statistics_do_not_depend_on_chunking_or_center():
    rng = np.random.default_rng(base_seed() + 13)
    affine = make_affine(1000, 3, 2, rng)
    a = sufficient_statistics(affine, ar_order=2)
    b = sufficient_statistics(affine, ar_order=2, chunk_size=7, center=np.zeros(2))
    lam = rng.standard_normal((5, 2))
    sigma, rho = np.full((5, 3), 0.7), np.full((5, 3, 2), 0.2)
    np.testing.assert_allclose(log_likelihood_ar(lam, sigma, rho, a), log_likelihood_ar(lam, sigma, rho, b), rtol=1e-9)


def test_plain_log_likelihood_is_paper_eq4():
    rng = np.random.default_rng(base_seed() + 14)
    r = rng.standard_normal((800, 2)) * [0.3, 2.0]
    var = np.mean(r**2, axis=0)
    expected = sum(-400 * (np.log(2 * np.pi * v) + 1) for v in var)
    assert plain_log_likelihood(r) == pytest.approx(expected, rel=1e-12)
    # Eq. 4 is the white likelihood maximised over sigma
    assert plain_log_likelihood(r) == pytest.approx(np.sum(stats.norm(0, np.sqrt(var)).logpdf(r)), rel=1e-12)


def test_statistics_validate_shapes():
    rng = np.random.default_rng(0)
    affine = make_affine(100, 2, 2, rng)
    bad = AffineReconstruction(
        affine.measured, affine.baseline[:, :1], affine.signatures, affine.estimate, affine.names
    )
    with pytest.raises(ShapeError, match="baseline"):
        sufficient_statistics(bad)
    st = sufficient_statistics(affine)
    with pytest.raises(ShapeError, match="trailing dimension"):
        log_likelihood_white(np.zeros(3), 1.0, st)
    with pytest.raises(InputDataError, match="ar_order"):
        log_likelihood_ar(np.zeros(2), 1.0, 0.5, st)


# ---------------------------------------------------------------------------------------------
# priors


def test_priors_are_proper_and_stated():
    scales = default_coefficient_scales([2.0, 0.5], reference_force_rms=10.0)
    np.testing.assert_allclose(scales, [5.0, 20.0])
    prior = coefficient_prior(["a", "b"], [2.0, 0.5], 10.0, overrides={"b": 1.0})
    np.testing.assert_allclose(prior.scale, [5.0, 1.0])
    assert "b ~ N(0, 1^2)" in prior.describe()
    # densities integrate to one (the second coordinate held at a point of known density)
    total = integrate.quad(lambda x: np.exp(prior.log_pdf(np.array([x, 0.0]))), -100, 100)[0]
    assert total == pytest.approx(1.0 / np.sqrt(2 * np.pi), rel=1e-8)
    noise = NoisePrior.from_std([2.0, 4.0])
    np.testing.assert_allclose(noise.lower, [2e-4, 4e-4])
    np.testing.assert_allclose(noise.upper, [20.0, 40.0])
    mass = integrate.quad(
        lambda s: np.exp(noise.log_pdf(np.array([s, 1.0]))), 2e-4, 20, points=[1e-3, 1e-2, 0.1, 1], limit=200
    )[0]
    assert mass == pytest.approx(1.0 / np.log(1e5), rel=1e-6)
    draws = noise.sample(1000, rng=1)
    assert np.all((draws >= noise.lower) & (draws <= noise.upper))
    assert np.all(np.abs(ARPrior().sample(100, rng=1)) < 0.9999)
    with pytest.raises(InputDataError):
        CoefficientPrior(("a",), [-1.0])
    rng = np.random.default_rng(0)
    affine = make_affine(200, 2, 2, rng)
    text = default_priors(affine, [1.0, 1.0], 3.0).describe()
    assert "log-uniform" in text and "uniform(-0.9999, 0.9999)" in text


# ---------------------------------------------------------------------------------------------
# exact evidence: checked against brute force, then used as the reference


def test_closed_form_equals_brute_force_quadrature():
    rng = np.random.default_rng(base_seed() + 21)
    affine = make_affine(60, 1, 1, rng, sigma=0.8, coefficients=[0.7])
    pri = make_priors(affine, scale=2.0)
    st = sufficient_statistics(affine)
    exact = closed_form_log_evidence(st, pri)
    r0 = (affine.measured - affine.baseline)[:, 0]
    g = affine.signatures[:, 0, 0]
    lo, hi = np.log(pri.noise.lower[0]), np.log(pri.noise.upper[0])

    # brute force: the direct likelihood on a 2-D Gauss-Legendre grid over (λ, log σ)
    u_hat = np.log(np.sqrt(np.mean((r0 - g * affine.estimate[0]) ** 2)))
    lam_sd = 0.8 / np.sqrt(g @ g)
    x, w = np.polynomial.legendre.leggauss(200)
    lam = affine.estimate[0] + 12 * lam_sd * x
    u = u_hat + 1.0 * x  # ±1 in log σ is more than ±10 posterior sd at N = 60
    r = r0[None, :] - lam[:, None] * g[None, :]  # (λ, sample)
    rss = np.sum(r**2, axis=1)
    loglik = -0.5 * len(r0) * (np.log(2 * np.pi) + 2 * u[None, :]) - 0.5 * rss[:, None] * np.exp(-2 * u[None, :])
    logpost = loglik + stats.norm(0, 2.0).logpdf(lam)[:, None] - np.log(hi - lo)
    logw = np.log(12 * lam_sd * w)[:, None] + np.log(1.0 * w)[None, :]
    brute = np.logaddexp.reduce((logpost + logw).ravel())
    assert brute == pytest.approx(exact, abs=1e-8)


@pytest.mark.parametrize("n_samples", [1000, 10_000, 100_000, 1_000_000])
@pytest.mark.parametrize("q", [1, 2, 3, 4])
def test_bridge_evidence_matches_closed_form(q, n_samples):
    # acceptance (docs/accuracy.md): q = 1..4 coefficients, 10^3..10^6 samples
    rng = np.random.default_rng(base_seed() + 100 * q + n_samples % 97)
    affine = make_affine(n_samples, 2, q, rng)
    result = marginal_evidence(affine, make_priors(affine), "white", rng=rng, **QUICK)
    exact = result.closed_form_log_evidence
    assert exact is not None
    assert abs(result.log_evidence - exact) <= max(EVIDENCE_NAT, 3 * result.log_evidence_se)
    assert abs(result.laplace_log_evidence - exact) <= LAPLACE_NAT
    assert result.log_evidence_se < 0.05
    assert result.convergence.converged, result.convergence.message()


def test_ar1_bridge_evidence_matches_closed_form():
    rng = np.random.default_rng(base_seed() + 31)
    affine = make_affine(2000, 1, 2, rng, rho=0.9, smooth=True)
    result = marginal_evidence(affine, make_priors(affine), "ar1", rng=rng, **QUICK)
    exact = result.closed_form_log_evidence
    assert abs(result.log_evidence - exact) <= max(EVIDENCE_NAT, 3 * result.log_evidence_se)
    rho_mean = result.summary.loc["rho[y0]", "mean"]
    assert rho_mean == pytest.approx(0.9, abs=0.05)


def test_laplace_alone_and_ar2_runs():
    rng = np.random.default_rng(base_seed() + 32)
    affine = make_affine(3000, 2, 2, rng, rho=0.5)
    pri = make_priors(affine)
    st = sufficient_statistics(affine, ar_order=2)
    lap = laplace_log_evidence(st, pri, "ar2")
    result = evidence_from_statistics(st, pri, "ar2", rng=rng, **QUICK)
    assert result.closed_form_log_evidence is None
    assert abs(result.log_evidence - lap) <= LAPLACE_NAT
    assert result.posterior.rho.shape[-2:] == (2, 2)
    with pytest.raises(InputDataError, match="quadrature"):
        closed_form_log_evidence(st, pri, "ar2")


@pytest.mark.parametrize("likelihood", ["white", "ar1"])
def test_evidence_at_one_million_samples_default_settings(likelihood):
    rng = np.random.default_rng(base_seed() + 41)
    affine = make_affine(1_000_000, 1 if likelihood == "ar1" else 2, 3, rng, rho=0.5 if likelihood == "ar1" else 0)
    result = marginal_evidence(affine, make_priors(affine), likelihood, rng=rng)
    assert abs(result.log_evidence - result.closed_form_log_evidence) <= max(EVIDENCE_NAT, 3 * result.log_evidence_se)


# ---------------------------------------------------------------------------------------------
# model selection


def test_occam_evidence_prefers_smaller_model_plain_ranking_the_larger():
    rng = np.random.default_rng(base_seed() + 51)
    big = make_affine(2000, 2, 2, rng, coefficients=[1.0, 0.0])  # second coefficient truly zero
    small = AffineReconstruction(
        measured=big.measured,
        baseline=big.baseline,
        signatures=big.signatures[:, :, :1],
        estimate=np.linalg.lstsq(big.signatures[:, :, :1].reshape(-1, 1),
                                 (big.measured - big.baseline).reshape(-1), rcond=None)[0],
        names=big.names[:1],
    )
    results = {}
    for name, aff in (("A", small), ("B", big)):
        results[name] = marginal_evidence(aff, make_priors(aff, scale=10.0), "white", rng=rng, **QUICK)
    # plain (paper) ranking: nested superset always has the larger likelihood
    assert results["B"].plain_log_likelihood > results["A"].plain_log_likelihood
    plain = plain_ranking([results["A"].plain_log_likelihood, results["B"].plain_log_likelihood], names=["A", "B"])
    assert plain.best == "B"
    # evidence: the Occam factor of the useless coefficient wins (≈ log(prior sd / posterior sd))
    post = posterior_probabilities(
        [results["A"].log_evidence, results["B"].log_evidence],
        log_evidence_se=[results["A"].log_evidence_se, results["B"].log_evidence_se],
        names=["A", "B"],
        rng=1,
    )
    assert post.best == "A"
    assert post.probability[0] > 0.95
    table = compare_evidence(results)
    assert table.loc["A", "p_white"] > 0.95 and table.loc["B", "p_plain"] > 0.5
    assert list(table.columns) == [
        "prior", "log_likelihood_plain", "p_plain", "log_evidence_white", "log_evidence_se_white", "p_white",
        "p_white_sd",
    ]


def test_posterior_probabilities_softmax_failed_candidates_and_uncertainty():
    out = posterior_probabilities([0.0, np.log(3.0), -np.inf, np.nan])
    np.testing.assert_allclose(out.probability, [0.25, 0.75, 0.0, 0.0])
    np.testing.assert_allclose(out.probability_sd, 0.0)
    weighted = posterior_probabilities([0.0, 0.0], priors=[1, 3])
    np.testing.assert_allclose(weighted.probability, [0.25, 0.75])
    # large evidences do not overflow
    np.testing.assert_allclose(posterior_probabilities([-1e6, -1e6 + np.log(9)]).probability, [0.1, 0.9])
    # Monte-Carlo uncertainty: delta method for two models, sd(p) = p(1-p) sqrt(se1² + se2²)
    noisy = posterior_probabilities([0.0, 0.0], log_evidence_se=[0.05, 0.05], rng=3, n_draws=20000)
    assert noisy.probability_sd[0] == pytest.approx(0.25 * np.sqrt(2) * 0.05, rel=0.05)
    assert np.all(np.isnan(posterior_probabilities([-np.inf, -np.inf]).probability))
    table = ranking_table(["a", "b"], [-10.0, -9.0], {"ar1": ([-12.0, -13.0], [0.01, 0.01])}, rng=0)
    assert table.loc["a", "p_ar1"] == pytest.approx(1 / (1 + np.exp(-1)), rel=1e-12)
    with pytest.raises(ShapeError):
        posterior_probabilities([0.0, 1.0], priors=[1.0])


# ---------------------------------------------------------------------------------------------
# sampling, arviz and convergence


def test_same_seed_same_result_and_datatree_dims():
    rng = np.random.default_rng(base_seed() + 61)
    affine = make_affine(1000, 2, 2, rng)
    pri = make_priors(affine)
    st = sufficient_statistics(affine)
    a = sample_posterior(st, pri, rng=5, n_walkers=16, n_steps=300, n_burn=100)
    b = sample_posterior(st, pri, rng=np.random.default_rng(5), n_walkers=16, n_steps=300, n_burn=100)
    c = sample_posterior(st, pri, rng=6, n_walkers=16, n_steps=300, n_burn=100)
    np.testing.assert_array_equal(a.samples, b.samples)
    assert not np.array_equal(a.samples, c.samples)
    assert a.samples.shape == (16, 200, 2 + 2)
    tree = a.to_datatree()
    post = tree["posterior"]
    assert post["coefficient"].dims == ("chain", "draw", "term")
    assert post["sigma"].dims == ("chain", "draw", "channel")
    assert post.sizes["chain"] == 16 and post.sizes["draw"] == 200
    assert tree["sample_stats"]["lp"].dims == ("chain", "draw")
    np.testing.assert_array_equal(post["coefficient"].values, a.coefficients)
    r1 = marginal_evidence(affine, pri, rng=9, **QUICK)
    r2 = marginal_evidence(affine, pri, rng=9, **QUICK)
    assert r1.log_evidence == r2.log_evidence
    assert list(r1.summary.columns) == [
        "mean", "sd", "hdi95_lb", "hdi95_ub", "ess_bulk", "ess_tail", "r_hat", "mcse_mean", "mcse_sd",
    ]
    assert r1.summary.index[0] == "coefficient[k0]"
    assert r1.ci95.shape == (2, 2)
    assert np.all(r1.ci95[:, 0] < r1.coefficient_mean) and np.all(r1.coefficient_mean < r1.ci95[:, 1])
    assert r1.to_dict()["coefficients"]["k0"]["hdi95"][0] == r1.ci95[0, 0]


def test_convergence_warning_for_too_short_run():
    rng = np.random.default_rng(base_seed() + 71)
    affine = make_affine(1000, 2, 2, rng)
    with pytest.warns(ConvergenceWarning, match=r"ESS = \d+ < 400.*more steps"):
        result = marginal_evidence(affine, make_priors(affine), rng=rng, n_walkers=16, n_steps=25, n_burn=5)
    assert not result.convergence.converged
    assert result.ess_min < 400
    assert any("ESS" in msg for msg in result.warnings)


def test_import_bayesnsi_evidence_loads_no_emcee_or_arviz():
    code = (
        "import sys, bayesnsi, bayesnsi.evidence; "
        "bad = [m for m in ('emcee', 'arviz_base', 'arviz_stats', 'arviz', 'matplotlib') if m in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
