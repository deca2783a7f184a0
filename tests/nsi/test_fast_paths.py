"""The fast per-channel reductions of identify() equal numpy's column-wise ones."""

from __future__ import annotations

import numpy as np

from bayesnsi.noise import column_std, white_noise_std


def _reference_white_noise_std(y):
    # the definition (docs: smallest var(Δᵈ y) / C(2d, d) over d = 2..6), numpy down the columns
    from math import comb

    return np.sqrt(np.min([np.diff(y, n=d, axis=0).var(axis=0) / comb(2 * d, d) for d in range(2, 7)], axis=0))


def test_white_noise_std_and_column_std_match_numpy():
    rng = np.random.default_rng(3)
    t = np.arange(20_000) / 100.0
    clean = np.column_stack([np.sin(2 * np.pi * 2.5 * t), 3 + np.cos(2 * np.pi * 7.5 * t)])
    y = clean + rng.normal(0, 0.02, clean.shape)
    np.testing.assert_allclose(white_noise_std(y), _reference_white_noise_std(y), rtol=1e-10)
    np.testing.assert_allclose(white_noise_std(y), 0.02, rtol=0.05)
    np.testing.assert_allclose(column_std(y), y.std(axis=0), rtol=1e-12)
    np.testing.assert_allclose(white_noise_std(y[::2]), white_noise_std(np.asfortranarray(y)[::2]), rtol=1e-12)


def _direct_lagged_products(z, n_lags):
    # the definition: T_d = sum_{t<j} z_t z_{t+d}^T, j = N - n_lags + 1
    j = len(z) - n_lags + 1
    return np.stack([z[:j].T @ z[d : d + j] for d in range(n_lags)])


def test_lagged_products_by_block_ffts_equal_the_definition():
    from bayesnsi.nsi import _hankel

    rng = np.random.default_rng(4)
    for n, k, lags in [(301, 3, 20), (5000, 5, 40), (9001, 4, 130), (700, 2, 16), (3000, 3, 7)]:
        z = rng.standard_normal((n, k))
        expected = _direct_lagged_products(z, lags)
        np.testing.assert_allclose(_hankel.lagged_products(z, lags), expected, rtol=1e-12, atol=1e-10 * n)
