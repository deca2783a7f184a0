"""Tests of bayesnsi.report and bayesnsi.plots (and the curves the figures draw)."""
