"""Tests of bayesnsi.checks: model adequacy, residual bands, validation, physical checks."""
