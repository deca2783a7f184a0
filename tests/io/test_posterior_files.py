"""The posterior draws written to DIR/posterior/<candidate>.nc load back as arviz DataTrees."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.evidence import SamplerRecord
from bayesnsi.exceptions import InputDataError
from bayesnsi.io.posterior import NETCDF_ENGINE, posterior_filename, read_posterior, write_posteriors
from tests._helpers.posteriors import posterior_samples as _posterior

SAMPLER = SamplerRecord(name="emcee", version="3.1.6", moves=("StretchMove",), weights=(1.0,), n_walkers=4,
                        n_steps=130, n_burn=10, parameters="all parameters")


def _evidence(q, log_z):
    return SimpleNamespace(posterior=_posterior(q), log_evidence=log_z, log_evidence_se=0.01, likelihood="ar1",
                           coefficient_names=[f"x1**{k + 2}@1" for k in range(q)], settings={}, sampler=SAMPLER)


def test_posteriors_round_trip_through_netcdf(tmp_path):
    xr = pytest.importorskip("xarray")
    arviz_stats = pytest.importorskip("arviz_stats")
    evidences = {"quadratic + cubic": _evidence(2, -10.5), "linear": _evidence(0, -20.0), "failed": None}
    files = write_posteriors(tmp_path, evidences)
    assert files == {"quadratic + cubic": "posterior/quadratic_cubic.nc", "linear": "posterior/linear.nc"}
    tree = read_posterior(tmp_path / files["quadratic + cubic"])
    original = evidences["quadratic + cubic"].posterior
    # without honest intervals the posterior is the sampler's own (given the linear part), and says so
    np.testing.assert_array_equal(tree["posterior"]["coefficient"].to_numpy(), original.coefficients)
    np.testing.assert_array_equal(tree["posterior_given_linear_part"]["coefficient"].to_numpy(), original.coefficients)
    np.testing.assert_array_equal(tree["sample_stats"]["lp"].to_numpy(), original.log_posterior)
    assert list(tree["posterior"]["coefficient"].dims) == ["chain", "draw", "term"]
    assert tree.attrs["model"] == "quadratic + cubic" and tree.attrs["log_evidence"] == -10.5
    assert tree.attrs["interval"] == "none" and tree.attrs["sampler"] == SAMPLER.describe()
    # what a notebook does: xarray opens it, arviz summarises it
    with xr.open_datatree(tmp_path / files["linear"], engine=NETCDF_ENGINE) as linear:
        assert "coefficient" not in linear["posterior"] and "sigma" in linear["posterior_given_linear_part"]
    summary = arviz_stats.summary(tree, var_names=["coefficient"])
    np.testing.assert_allclose(summary["mean"], original.coefficients.mean(axis=(0, 1)), atol=0.01)
    assert not list(tmp_path.glob("posterior/.*partial"))


def test_posterior_file_names_are_safe_and_distinct():
    assert posterior_filename("quadratic + cubic") == "quadratic_cubic.nc"
    assert posterior_filename("../../etc/passwd") == "etc_passwd.nc"
    assert posterior_filename("a/b", {"a_b.nc"}) == "a_b-2.nc"
    assert posterior_filename("+++") == "candidate.nc"


def test_reading_a_missing_posterior_is_bad_input(tmp_path):
    with pytest.raises(InputDataError, match="not found"):
        read_posterior(tmp_path / "nope.nc")


def test_posterior_group_carries_the_honest_intervals_and_the_given_linear_part_group_the_samplers():
    """arviz's summary of a file gives the honest 95 % interval of results.json (to the draws' resolution), and
    the group of its own the sampler's narrower interval; reference: the intervals written, computed apart."""
    arviz_stats = pytest.importorskip("arviz_stats")
    from bayesnsi.io.posterior import posterior_tree
    from bayesnsi.uncertainty import Intervals, ParameterInterval

    evidence = _evidence(2, -10.5)
    honest = tuple(ParameterInterval(name=name, estimate=2.0 + k, sd=2.6, posterior_sd=1.0, segment_sd=2.4,
                                     ci50=(0.2 + k, 3.8 + k), ci95=(-3.0 + k, 7.5 + k), bias=-0.05)
                   for k, name in enumerate(evidence.coefficient_names))
    tree = posterior_tree("m", evidence, Intervals(method="noise", coefficients=honest, n_segments=16))
    summary = arviz_stats.summary(tree, ci_prob=0.95, var_names=["coefficient"])
    for k, p in enumerate(honest):
        low, high = summary.iloc[k][["eti95_lb", "eti95_ub"]].to_numpy(dtype=float)
        width = p.ci95[1] - p.ci95[0]
        assert abs(low - p.ci95[0]) < 0.02 * width and abs(high - p.ci95[1]) < 0.02 * width
    given = arviz_stats.summary(tree, ci_prob=0.95, var_names=["coefficient"], group="posterior_given_linear_part")
    assert np.all(given["sd"].to_numpy(dtype=float) < summary["sd"].to_numpy(dtype=float))
    assert tree["posterior"]["coefficient"].attrs["units"] == ["", ""]  # the data state no units here
    assert "honest intervals" in tree["posterior"]["coefficient"].attrs["description"]


def test_posterior_file_names_the_sampler_that_ran(tmp_path):
    from bayesnsi.evidence import evidence_from_statistics, sufficient_statistics
    from tests._helpers.affine import make_affine, make_priors

    affine = make_affine(2000, 2, 1, np.random.default_rng(5), smooth=True)
    stats = sufficient_statistics(affine, ar_order=1)
    evidences = {"cubic": evidence_from_statistics(stats, make_priors(affine), "white", rng=3, warn=False,
                                                  n_steps=400, n_burn=50)}
    files = write_posteriors(tmp_path, evidences)
    attrs = read_posterior(tmp_path / files["cubic"])["posterior"].attrs
    record = evidences["cubic"].sampler
    assert attrs["sampler"] == record.describe()
    assert attrs["sampler"].startswith("emcee ") and f"{record.n_walkers} walkers x {record.n_steps} steps" in attrs[
        "sampler"]


def test_log_likelihood_group_scores_record_blocks_and_loo_prefers_the_true_model(tmp_path):
    """The file's log_likelihood group: white blocks sum to the record's log-likelihood at every draw
    (independent: the full record's sufficient statistics), and arviz_stats.loo on the written files
    ranks the simulated truth (model 1, v1|v1|) above model 2 (sign(v1)) by many standard errors."""
    arviz_stats = pytest.importorskip("arviz_stats")
    import bayesnsi
    from bayesnsi.evidence import candidate_affine, log_likelihood_white, sufficient_statistics
    from bayesnsi.options import EvidenceOptions, NSIOptions
    from bayesnsi.simulate import CASES

    case = CASES["two-dof"](seed=1, duration=30.0)
    options = EvidenceOptions(likelihood="white", compare=())
    selection = bayesnsi.select(case.signals, case.candidates[:2], NSIOptions(block_rows=40, order=4), options)
    files = write_posteriors(tmp_path, {o.candidate.name: o.evidences["white"] for o in selection.outcomes})
    elpd = {}
    for outcome in selection.outcomes:
        evidence = outcome.evidences["white"]
        tree = read_posterior(tmp_path / files[outcome.candidate.name])
        blocks = tree["log_likelihood"]["response"]
        assert blocks.dims == ("chain", "draw", "block") and blocks.sizes["block"] == 20
        stats = sufficient_statistics(candidate_affine(outcome.result, case.signals, options.residual))
        draws = evidence.posterior
        full = log_likelihood_white(draws.coefficients, draws.sigma, stats)
        np.testing.assert_allclose(blocks.to_numpy().sum(axis=-1), full, rtol=1e-9)
        with warnings.catch_warnings():  # the wrong model's misfit blocks are influential (Pareto k > 0.7)
            warnings.filterwarnings("ignore", message="Estimated shape parameter of Pareto", category=UserWarning)
            found = arviz_stats.loo(tree)
        elpd[outcome.candidate.name] = (float(found.elpd), float(found.se))
    (best, best_se), (other, other_se) = elpd["model 1"], elpd["model 2"]
    assert best - other > 5 * np.hypot(best_se, other_se)
