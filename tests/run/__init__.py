"""Tests of bayesnsi.run and bayesnsi.selection: batches of candidates, their dispatch and limits."""
