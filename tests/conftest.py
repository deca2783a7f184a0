"""Shared fixtures and helpers."""

import os

import numpy as np
import pytest
from scipy.linalg import expm


def base_seed() -> int:
    """Seed offset for stochastic tests (override with BAYESNSI_TEST_SEED)."""
    return int(os.environ.get("BAYESNSI_TEST_SEED", "0"))


@pytest.fixture
def rng():
    return np.random.default_rng(base_seed())


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
