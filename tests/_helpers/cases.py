"""Seeds, simulated reference cases and exactly discretised chains shared by tests of several packages."""

import functools
import os

import numpy as np
from scipy.linalg import expm


def base_seed() -> int:
    """Seed offset for stochastic tests (override with BAYESNSI_TEST_SEED)."""
    return int(os.environ.get("BAYESNSI_TEST_SEED", "0"))


@functools.lru_cache(maxsize=2)
def twin_case(seed: int = 0):
    """``simulate_case("negative-stiffness", seed=seed)``, simulated once per test process.

    The twin's RK4 march (140 s on a 6x grid, 25-40 s) is shared by the tests that read it; they
    must not modify the returned case.
    """
    from bayesnsi.simulate import simulate_case

    return simulate_case("negative-stiffness", seed=seed)


def zoh_chain(masses, stiffnesses, dampings, dt, force_dofs):
    """Exact ZOH discretisation of a chain (SPEC Eq. 18), for tests independent of the simulator.

    Returns Ac, Bc (force columns), A, B, n_dofs.
    """
    n = len(masses)
    K = np.zeros((n, n))
    C = np.zeros((n, n))
    for idx, (k, c) in enumerate(zip(stiffnesses, dampings)):
        K[idx, idx] += k
        C[idx, idx] += c
        if idx > 0:
            K[idx - 1, idx - 1] += k
            K[idx - 1, idx] -= k
            K[idx, idx - 1] -= k
            C[idx - 1, idx - 1] += c
            C[idx - 1, idx] -= c
            C[idx, idx - 1] -= c
    M = np.diag(masses)
    minv = np.linalg.inv(M)
    Ac = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ K, -minv @ C]])
    Bfull = np.vstack([np.zeros((n, n)), minv])
    A = expm(Ac * dt)
    Bd_full = np.linalg.solve(Ac, (A - np.eye(2 * n)) @ Bfull)
    return Ac, A, Bd_full, n
