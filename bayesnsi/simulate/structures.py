"""Linear structural matrices: spring-mass chains and Euler-Bernoulli cantilevers (docs/method.md §8).

Conventions: DOFs are numbered from 1 in the documentation and stored from 0 in the
matrices; masses in kg, stiffnesses in N/m, dampings in N s/m, frequencies in Hz
(``*_hz``) and angular frequencies in rad/s (``omega``).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import InputDataError, ShapeError, UnstableModelError
from ._fixed_order import generalized_eigh, product

__all__ = ["chain_system", "cantilever_beam", "modal_damping", "modal_parameters", "state_matrix", "underlying_frf"]


def chain_system(masses, stiffnesses, dampings):
    """Mass, damping and stiffness matrices of a grounded spring-mass chain.

    Topology: ground - k_1 - m_1 - k_2 - m_2 - ... - k_N - m_N; spring (and damper) ``i``
    connects DOF ``i - 1`` to DOF ``i`` (the ground for ``i = 1``). This is the two-DOF system
    of docs/method.md §8 (paper section III.A) for ``N = 2``.

    Parameters
    ----------
    masses : array_like, shape (N,)
        Masses m_i [kg], all positive.
    stiffnesses : array_like, shape (N,)
        Spring stiffnesses k_i [N/m], non-negative.
    dampings : array_like, shape (N,)
        Viscous damper coefficients c_i [N s/m], non-negative, same topology as the springs.

    Returns
    -------
    M, C, K : ndarray, shape (N, N)
        Mass [kg], damping [N s/m] and stiffness [N/m] matrices.

    Examples
    --------
    >>> M, C, K = chain_system([1.0, 1.5], [800.0, 1000.0], [1.0, 1.0])
    >>> K
    array([[ 1800., -1000.],
           [-1000.,  1000.]])
    """
    m = _positive_vector("masses", masses, strict=True)
    k = _positive_vector("stiffnesses", stiffnesses, strict=False)
    c = _positive_vector("dampings", dampings, strict=False)
    if not (len(m) == len(k) == len(c)):
        raise ShapeError(
            f"masses, stiffnesses and dampings need one value per DOF; got lengths "
            f"{len(m)}, {len(k)}, {len(c)}"
        )
    return np.diag(m), _chain_matrix(c), _chain_matrix(k)


def cantilever_beam(
    n_elements: int = 8,
    length: float = 0.5,
    youngs_modulus: float = 2.0453e6,
    density: float = 1200.0,
    area: float = 5e-4,
    inertia: float | None = None,
    rotary_inertia_factor: float = 4.0,
):
    """Lumped-mass Euler-Bernoulli cantilever (docs/method.md §8, paper section III.B).

    Parameters
    ----------
    n_elements : int
        Number of equal beam elements; the beam is clamped at node 0.
    length : float
        Beam length L [m].
    youngs_modulus : float
        Young's modulus E [Pa]. The paper's "7×10⁷ GPa" is a typo (docs/method.md §8). docs/method.md §8 reads
        it as 2.044 MPa, which gives Table 6 to 0.041 % (4.308 Hz against 4.310 Hz); the
        default 2.0453 MPa reproduces all ten printed frequencies to their last digit
        (the frequencies scale as sqrt(E), so the two readings differ by 0.032 %).
    density : float
        Density ρ [kg/m³].
    area : float
        Cross-section area A [m²].
    inertia : float, optional
        Second moment of area I [m⁴]; default ``area**2 / (4*pi)`` (circular section).
    rotary_inertia_factor : float
        κ in the nodal rotary inertia κ·ρA·le³/2 contributed by each element end.

    Returns
    -------
    M, K : ndarray, shape (2 n_elements, 2 n_elements)
        Lumped (diagonal) mass matrix [kg, kg m²] and stiffness matrix. DOF order
        w_1, θ_1, w_2, θ_2, ...: DOF ``2j - 1`` (1-based) is the transverse displacement
        [m] of node ``j`` and DOF ``2j`` its rotation [rad]; with 8 elements DOF 13 is w at
        node 7 and DOF 15 is w at the tip.

    Notes
    -----
    Element stiffness (Hermite cubics, le = L / n_elements)::

        EI/le³ [[ 12,    6le,  -12,    6le ],
                [ 6le,  4le²,  -6le,  2le² ],
                [-12,   -6le,   12,   -6le ],
                [ 6le,  2le²,  -6le,  4le² ]]

    Lumped mass: each element end receives a translational mass ρA·le/2 and a rotary
    inertia κ·ρA·le³/2 (docs/method.md §8). With the defaults the natural frequencies rounded to
    1 mHz are 0.509, 2.098, 4.310, 6.266, 7.934, 9.221, 10.105, 10.554, 18.648, 27.132 Hz,
    exactly paper Table 6, and all 16 modes lie below 74 Hz.

    References
    ----------
    Zhu, Fei, Jiang, Marchesiello, Anastasio, "Bayesian Model Selection in Nonlinear Subspace
    Identification", AIAA J., section III.B, Tables 5-6.
    """
    if int(n_elements) != n_elements or n_elements < 1:
        raise InputDataError(f"n_elements must be a positive integer, got {n_elements!r}")
    n_elements = int(n_elements)
    for name, value in (
        ("length", length),
        ("youngs_modulus", youngs_modulus),
        ("density", density),
        ("area", area),
    ):
        if not (np.isfinite(value) and value > 0):
            raise InputDataError(f"{name} must be a positive number, got {value!r}")
    if inertia is None:
        inertia = area**2 / (4.0 * np.pi)
    if not (np.isfinite(inertia) and inertia > 0):
        raise InputDataError(f"inertia must be a positive number, got {inertia!r}")
    if not (np.isfinite(rotary_inertia_factor) and rotary_inertia_factor >= 0):
        raise InputDataError(f"rotary_inertia_factor must be >= 0, got {rotary_inertia_factor!r}")

    le = length / n_elements
    ei = youngs_modulus * inertia
    ke = (ei / le**3) * np.array(
        [
            [12.0, 6.0 * le, -12.0, 6.0 * le],
            [6.0 * le, 4.0 * le**2, -6.0 * le, 2.0 * le**2],
            [-12.0, -6.0 * le, 12.0, -6.0 * le],
            [6.0 * le, 2.0 * le**2, -6.0 * le, 4.0 * le**2],
        ]
    )
    rho_a = density * area
    me = np.array([rho_a * le / 2, rotary_inertia_factor * rho_a * le**3 / 2] * 2)

    n_full = 2 * (n_elements + 1)
    k_full = np.zeros((n_full, n_full))
    m_full = np.zeros(n_full)
    for e in range(n_elements):
        idx = slice(2 * e, 2 * e + 4)
        k_full[idx, idx] += ke
        m_full[idx] += me
    # clamp node 0 (its w and θ are the first two global DOFs)
    return np.diag(m_full[2:]), k_full[2:, 2:].copy()


def modal_damping(M, K, damping_ratios):
    """Damping matrix with prescribed modal damping ratios.

    Parameters
    ----------
    M, K : array_like, shape (N, N)
        Symmetric positive definite mass and symmetric stiffness matrices.
    damping_ratios : float or array_like, shape (N,)
        Damping ratio ζ_r of each mode (in order of increasing frequency), e.g. 0.01 for 1 %.

    Returns
    -------
    C : ndarray, shape (N, N)
        ``C = M Φ diag(2 ζ_r ω_r) Φᵀ M`` with mass-normalised modes Φ (Φᵀ M Φ = I), so that
        Φᵀ C Φ = diag(2 ζ_r ω_r) exactly.
    """
    M, K = _square("M", M), _square("K", K)
    if M.shape != K.shape:
        raise ShapeError(f"M and K must have the same shape, got {M.shape} and {K.shape}")
    # in a fixed order of operations: a chaotic case's record must not depend on the CPU (_fixed_order.py)
    omega_sq, phi = generalized_eigh(K, M)
    if np.any(omega_sq < -1e-9 * np.abs(omega_sq).max()):
        raise UnstableModelError(
            "K has negative eigenvalues relative to M (a statically unstable structure); "
            "modal damping needs a stable linear structure"
        )
    omega = np.sqrt(np.clip(omega_sq, 0.0, None))
    zeta = np.broadcast_to(np.asarray(damping_ratios, dtype=float), omega.shape)
    mp = product(M, phi)
    C = product(mp * (2.0 * zeta * omega), mp.T)
    return 0.5 * (C + C.T)


def modal_parameters(M, C, K):
    """Natural frequencies and damping ratios of ``M ẅ + C ẇ + K w = 0``.

    Parameters
    ----------
    M, C, K : array_like, shape (N, N)
        Mass, damping and stiffness matrices.

    Returns
    -------
    frequencies_hz : ndarray, shape (n_modes,)
        Undamped natural frequencies f_r = |s_r| / 2π [Hz], ascending.
    damping_ratios : ndarray, shape (n_modes,)
        ζ_r = -Re(s_r) / |s_r| (dimensionless).

    Notes
    -----
    ``s_r`` are the eigenvalues with positive imaginary part of the first-order state
    matrix ``[[0, I], [-M⁻¹K, -M⁻¹C]]``; these are the exact reference values the NSI
    modes (docs/method.md §4) are compared with. Overdamped (real) poles are not modes and are left
    out, so ``n_modes <= N``.
    """
    M, C, K = _square("M", M), _square("C", C), _square("K", K)
    if not (M.shape == C.shape == K.shape):
        raise ShapeError(f"M, C, K must have the same shape, got {M.shape}, {C.shape}, {K.shape}")
    poles = np.linalg.eigvals(state_matrix(M, C, K))
    scale = np.abs(poles).max() if poles.size else 1.0
    osc = poles[poles.imag > 1e-10 * scale]
    omega = np.abs(osc)
    order = np.argsort(omega)
    omega, osc = omega[order], osc[order]
    return omega / (2.0 * np.pi), -osc.real / omega


def state_matrix(M, C, K) -> np.ndarray:
    """First-order state matrix ``[[0, I], [-M⁻¹K, -M⁻¹C]]`` for the state ``[w; ẇ]``.

    Parameters
    ----------
    M, C, K : ndarray, shape (N, N)
        Mass (invertible), damping and stiffness matrices.

    Returns
    -------
    ndarray, shape (2N, 2N)
    """
    n = M.shape[0]
    minv_k = np.linalg.solve(M, K)
    minv_c = np.linalg.solve(M, C)
    return np.block([[np.zeros((n, n)), np.eye(n)], [-minv_k, -minv_c]])


def underlying_frf(M, C, K, freqs_hz, output_dofs, input_dofs) -> np.ndarray:
    """Exact receptance of the underlying linear structure, ``H(ω) = [K - ω²M + jωC]⁻¹``.

    Parameters
    ----------
    M, C, K : array_like, shape (N, N)
        Mass, damping and stiffness matrices (e.g. ``ReferenceCase.M``).
    freqs_hz : array_like, shape (n_freqs,)
        Frequencies [Hz].
    output_dofs, input_dofs : sequence of int
        DOFs (1-based) of the rows (displacements) and columns (forces) returned.

    Returns
    -------
    ndarray, complex, shape (n_freqs, len(output_dofs), len(input_dofs))
        Displacement per unit force [m/N].

    Raises
    ------
    InputDataError
        If a DOF lies outside 1..N or a frequency is not finite.
    ShapeError
        If the matrices are not square and of one size.

    Examples
    --------
    >>> M, C, K = chain_system([1.0], [100.0], [0.0])
    >>> complex(underlying_frf(M, C, K, [0.0], [1], [1])[0, 0, 0])
    (0.01+0j)
    """
    M, C, K = _square("M", M), _square("C", C), _square("K", K)
    if not (M.shape == C.shape == K.shape):
        raise ShapeError(f"M, C, K must have the same shape, got {M.shape}, {C.shape}, {K.shape}")
    n = M.shape[0]
    outs, ins = (np.atleast_1d(np.asarray(d, dtype=int)) for d in (output_dofs, input_dofs))
    if outs.size == 0 or ins.size == 0 or min(outs.min(), ins.min()) < 1 or max(outs.max(), ins.max()) > n:
        raise InputDataError(f"output and input DOFs must lie in 1..{n}, got {outs.tolist()} and {ins.tolist()}")
    omega = 2.0 * np.pi * np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    if not np.all(np.isfinite(omega)):
        raise InputDataError("freqs_hz holds NaN or Inf values")
    forcing = np.eye(n)[:, ins - 1]
    dynamic = K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None]
    return np.linalg.solve(dynamic, np.broadcast_to(forcing, (len(omega), n, len(ins))))[:, outs - 1, :]


def _chain_matrix(values: np.ndarray) -> np.ndarray:
    n = len(values)
    out = np.zeros((n, n))
    for i, value in enumerate(values):
        out[i, i] += value
        if i > 0:
            out[i - 1, i - 1] += value
            out[i - 1, i] -= value
            out[i, i - 1] -= value
    return out


def _positive_vector(name: str, values, strict: bool) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ShapeError(f"{name} must be a non-empty 1-D sequence, got shape {arr.shape}")
    bad = ~np.isfinite(arr) | ((arr <= 0) if strict else (arr < 0))
    if bad.any():
        kind = "positive" if strict else "non-negative"
        raise InputDataError(f"{name} must be {kind} and finite, got {arr.tolist()}")
    return arr


def _square(name: str, matrix) -> np.ndarray:
    arr = np.atleast_2d(np.asarray(matrix, dtype=float))
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ShapeError(f"{name} must be a square matrix, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputDataError(f"{name} holds NaN or Inf values")
    return arr
