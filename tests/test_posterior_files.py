"""The posterior draws written to DIR/posterior/<candidate>.nc load back as arviz DataTrees (issue 16)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.exceptions import InputDataError
from bayesnsi.io.posterior import NETCDF_ENGINE, posterior_filename, read_posterior, write_posteriors

from .test_plots import _posterior


def _evidence(q, log_z):
    return SimpleNamespace(posterior=_posterior(q), log_evidence=log_z, log_evidence_se=0.01)


def test_posteriors_round_trip_through_netcdf(tmp_path):
    xr = pytest.importorskip("xarray")
    arviz_stats = pytest.importorskip("arviz_stats")
    evidences = {"quadratic + cubic": {"ar1": _evidence(2, -10.5)}, "linear": {"ar1": _evidence(0, -20.0)},
                 "failed": {}}
    files = write_posteriors(tmp_path, evidences, "ar1")
    assert files == {"quadratic + cubic": "posterior/quadratic_cubic.nc", "linear": "posterior/linear.nc"}
    tree = read_posterior(tmp_path / files["quadratic + cubic"])
    original = evidences["quadratic + cubic"]["ar1"].posterior
    np.testing.assert_array_equal(tree["posterior"]["coefficient"].to_numpy(), original.coefficients)
    np.testing.assert_array_equal(tree["sample_stats"]["lp"].to_numpy(), original.log_posterior)
    assert list(tree["posterior"]["coefficient"].dims) == ["chain", "draw", "term"]
    assert tree.attrs["candidate"] == "quadratic + cubic" and tree.attrs["log_evidence"] == -10.5
    # what a notebook does: xarray opens it, arviz summarises it
    with xr.open_datatree(tmp_path / files["linear"], engine=NETCDF_ENGINE) as linear:
        assert "coefficient" not in linear["posterior"] and "sigma" in linear["posterior"]
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


def test_posterior_file_names_the_sampler_that_ran(tmp_path):
    from bayesnsi.evidence import evidence_from_statistics, sufficient_statistics

    from .test_evidence import make_affine, make_priors

    affine = make_affine(2000, 2, 1, np.random.default_rng(5), smooth=True)
    stats = sufficient_statistics(affine, ar_order=1)
    evidences = {"cubic": {"white": evidence_from_statistics(stats, make_priors(affine), "white", rng=3, warn=False,
                                                            n_steps=400, n_burn=50)}}
    files = write_posteriors(tmp_path, evidences, "white")
    attrs = read_posterior(tmp_path / files["cubic"])["posterior"].attrs
    record = evidences["cubic"]["white"].sampler
    assert attrs["sampler"] == record.describe()
    assert attrs["sampler"].startswith("emcee ") and f"{record.n_walkers} walkers x {record.n_steps} steps" in attrs[
        "sampler"]
