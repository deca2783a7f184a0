"""The recursive filters of the modal simulation (bayesnsi/nsi/_recursion.py) against
``scipy.signal.lfilter`` (the reference: the same filters, as the simulation computed them before),
and the identify command's start-up without scipy.signal, matplotlib (``--no-figures``).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.signal import lfilter

from bayesnsi.nsi._recursion import CACHED_SAMPLES, delayed_first_order

SHAPES = [(1,), (2,), (3, 2), (500,), (500, 3), (40, 2, 2)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("pole", [0.97, -0.5, 0.9 * np.exp(0.3j), 1.0 - 1e-4 + 1e-4j])
def test_delayed_first_order_is_lfilter(shape, pole):
    rng = np.random.default_rng(len(shape) + sum(shape))
    x = rng.standard_normal(shape)
    complex_ = np.iscomplexobj(pole)
    zi = rng.standard_normal((1, *shape[1:])) * (1 + 0.5j if complex_ else 1.0)
    y_ref, zf_ref = lfilter([0.0, 1.0], [1.0, -pole], x.astype(complex) if complex_ else x, axis=0, zi=zi)
    y, zf = delayed_first_order(pole, x, zi)
    assert y.shape == y_ref.shape and zf.shape == zf_ref.shape and y.dtype == y_ref.dtype
    np.testing.assert_allclose(y, y_ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(zf, zf_ref, rtol=1e-12, atol=1e-12)


def test_an_empty_chunk_keeps_the_state():
    state = np.array([[0.3, -1.0]])
    y, zf = delayed_first_order(0.9j, np.empty((0, 2)), state)
    assert y.shape == (0, 2) and np.array_equal(zf, state)


def test_chunks_continue_the_recursion():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((40_000, 2))  # longer than CACHED_SAMPLES: filtered in chunks inside too
    lam = 0.99 * np.exp(0.05j)
    y_ref, _ = lfilter([0.0, 1.0], [1.0, -lam], x.astype(complex), axis=0, zi=np.zeros((1, 2), complex))
    np.testing.assert_allclose(delayed_first_order(lam, x)[0], y_ref, rtol=1e-12, atol=1e-12)
    assert len(x) > CACHED_SAMPLES
    whole, _ = delayed_first_order(lam, x)
    first, state = delayed_first_order(lam, x[:1])
    second, _ = delayed_first_order(lam, x[1:], state)
    np.testing.assert_allclose(np.concatenate([first, second]), whole, rtol=1e-12, atol=1e-12)


def test_identify_command_without_figures_imports_neither_scipy_signal_nor_matplotlib(tmp_path):
    from bayesnsi.cli import main

    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    code = (
        "import sys\nfrom bayesnsi.cli import main\n"
        f"code = main(['identify', {str(csv.with_suffix('.toml'))!r}, '--out', {str(tmp_path / 'out')!r}, "
        "'--quiet', '--no-figures', '--no-cache'])\n"
        "print(code, sorted(m for m in ('scipy.signal', 'matplotlib', 'scipy.integrate') if m in sys.modules))\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert run.stdout.split("\n")[-2] == "0 []", run.stdout + run.stderr
    assert (tmp_path / "out" / "results.json").exists()
