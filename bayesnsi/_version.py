"""The version of bayesnsi, in a leaf module that every other module may import without cycles."""

__all__ = ["__version__"]

__version__ = "0.1.0"
"""Package version; the same string as ``version`` in pyproject.toml (checked by tests/test_version.py)."""
