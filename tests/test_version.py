"""The version string of bayesnsi has one source of truth per place it is written down.

``bayesnsi.__version__`` (from ``bayesnsi/_version.py``) enters every cache key and every
result file, and ``version`` in pyproject.toml is what the installed metadata reports: the two
must agree, or cached results would be keyed by a version that is not the installed one.
"""

from __future__ import annotations

import importlib.metadata
import tomllib
from pathlib import Path

import bayesnsi
from bayesnsi import _fingerprint, _version

ROOT = Path(__file__).resolve().parents[1]


def test_version_matches_installed_metadata():
    assert bayesnsi.__version__ == importlib.metadata.version("bayesnsi")


def test_version_matches_pyproject():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert bayesnsi.__version__ == project["version"]


def test_version_has_a_single_definition():
    assert bayesnsi.__version__ is _version.__version__
    assert _fingerprint.__version__ is _version.__version__
