"""Tests of bayesnsi.simulate: structures, excitation, integration, the reference cases."""
