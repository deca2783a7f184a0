"""Helpers shared by the test files of several packages (records, configs, synthetic objects; no tests).

A test file imports what it shares with another package's tests from here, never from another
test file; fixtures shared by every test live in ``tests/conftest.py``.
"""
