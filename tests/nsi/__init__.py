"""Tests of bayesnsi.nsi: identification in the time and frequency domains, free bodies, the band mean."""
