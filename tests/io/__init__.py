"""Tests of bayesnsi.io: configs, loaders, the cache, the files bayesnsi writes, sensor conversions on load."""
