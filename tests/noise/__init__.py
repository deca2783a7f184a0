"""Tests of bayesnsi.noise: noise levels and replicates of the sensors as measured."""
