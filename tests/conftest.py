"""Fixtures shared by the tests of several packages, and the hypothesis profiles."""

import os

import numpy as np
import pytest

from tests._helpers.cases import base_seed
from tests._helpers.experiments import SELECT_CONFIG

try:
    from hypothesis import HealthCheck, settings
except ImportError:  # pragma: no cover - hypothesis is a test dependency
    settings = None

if settings is not None:
    # Property-based suites without an explicit max_examples follow the active profile:
    # "bayesnsi" (default, bounded for `make test`) or "long" (thousands of examples):
    #   BAYESNSI_HYPOTHESIS_PROFILE=long .venv/bin/pytest -q tests/io/test_fuzz.py
    _quiet = [HealthCheck.too_slow, HealthCheck.filter_too_much]
    settings.register_profile("bayesnsi", max_examples=60, deadline=None, suppress_health_check=_quiet)
    settings.register_profile("long", max_examples=3000, deadline=None, suppress_health_check=_quiet)
    settings.load_profile(os.environ.get("BAYESNSI_HYPOTHESIS_PROFILE", "bayesnsi"))


@pytest.fixture
def rng():
    return np.random.default_rng(base_seed())


@pytest.fixture(scope="module")
def select_config(tmp_path_factory):
    """A two-DOF record (10 s) with one candidate and a short MCMC: a select of about 2 s."""
    from bayesnsi.cli import main

    folder = tmp_path_factory.mktemp("select_config")
    csv = folder / "two_dof.csv"
    assert main(["simulate", "two-dof", "--seed", "1", "--duration", "10", "--out", str(csv), "--quiet"]) == 0
    path = folder / "select.toml"
    path.write_text(SELECT_CONFIG)
    return path
