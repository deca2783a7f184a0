"""Tests of bayesnsi.uncertainty: intervals by noise replicates, model replicates, segments, widening."""
