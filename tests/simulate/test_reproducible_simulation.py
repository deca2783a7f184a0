"""A seed gives the same record on every CPU: the simulator's fixed-order arithmetic (simulate/_fixed_order.py).

The beam's response is chaotic (docs/method.md §8): a difference in the last bit of one product grows
until, seconds into the record, the trajectory is another one. References: numpy's and scipy's BLAS and
LAPACK results (to rounding), and the same simulation run with other OpenBLAS kernels (to the bit).
"""

import os
import platform
import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from bayesnsi.simulate import cantilever_beam, modal_damping, simulate_case, simulate_cases
from bayesnsi.simulate._fixed_order import cholesky, generalized_eigh, inverse, product


def test_fixed_order_algebra_agrees_with_lapack_to_rounding():
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((7, 5)), rng.standard_normal((5, 3))
    np.testing.assert_allclose(product(a, b), a @ b, rtol=0, atol=1e-14)
    square = rng.standard_normal((6, 6))
    np.testing.assert_allclose(inverse(square) @ square, np.eye(6), rtol=0, atol=1e-13)
    spd = square @ square.T + 6 * np.eye(6)
    np.testing.assert_allclose(cholesky(spd), np.linalg.cholesky(spd), rtol=0, atol=1e-14)
    with pytest.raises(np.linalg.LinAlgError):
        inverse(np.ones((3, 3)))
    M, K = cantilever_beam()
    values, vectors = generalized_eigh(K, M)
    np.testing.assert_allclose(values, scipy.linalg.eigh(K, M, eigvals_only=True), rtol=1e-11)
    np.testing.assert_allclose(vectors.T @ M @ vectors, np.eye(16), rtol=0, atol=1e-13)
    np.testing.assert_allclose(vectors.T @ K @ vectors, np.diag(values), rtol=0, atol=1e-13 * values.max())
    w, phi = scipy.linalg.eigh(K, M)
    mp = M @ phi
    np.testing.assert_allclose(modal_damping(M, K, 0.01), mp @ np.diag(0.02 * np.sqrt(w)) @ mp.T,
                               rtol=0, atol=1e-13 * np.abs(mp @ np.diag(np.sqrt(w)) @ mp.T).max())


def test_a_beam_record_is_the_same_alone_and_in_a_batch():
    alone = simulate_case("beam", seed=3, duration=2.0)
    batch = simulate_cases("beam", [5, 3], duration=2.0)
    np.testing.assert_array_equal(batch[1].clean.displacement, alone.clean.displacement)
    np.testing.assert_array_equal(batch[1].signals.velocity, alone.signals.velocity)


_RECORD = (
    "import hashlib, numpy as np; from bayesnsi.simulate import simulate_case; "
    "c = simulate_case('beam', seed=0, duration=4.0); "
    "print(hashlib.sha256(np.ascontiguousarray(c.signals.displacement).tobytes()).hexdigest())"
)


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS x86-64 kernel names")
def test_a_beam_record_does_not_depend_on_the_blas_kernels():
    """The machine's own kernels (SkylakeX on an AVX-512 CPU) against the SSE-only Nehalem kernels, which
    every x86-64 CPU runs: the 4 s record's bytes are equal (with BLAS products in the RK4 loop they differ
    from the first steps on, and by 28 % of the range after 100 s)."""
    digests = []
    for coretype in (None, "Nehalem"):
        env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
        if coretype:
            env["OPENBLAS_CORETYPE"] = coretype
        done = subprocess.run([sys.executable, "-c", _RECORD], env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        digests.append(done.stdout.strip())
    assert digests[0] == digests[1]
