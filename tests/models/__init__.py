"""Tests of bayesnsi.models: the candidate-term language and candidate models."""
