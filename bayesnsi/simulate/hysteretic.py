"""Reference simulation of structures with Bouc-Wen hysteretic elements (docs/method.md §12).

    M ẅ + C ẇ + K w + Σ_i λ_i l_i n_i(w, ẇ) + Σ_j λ_j l_j z_j = F f(t),
    ż_j = u̇_j - β_j |u̇_j| |z_j|^(n_j-1) z_j - γ_j u̇_j |z_j|^(n_j),   z_j(0) = 0,

with u_j the displacement element j follows (``x_k`` or ``x_j - x_k``). The state is augmented with
the z_j and the whole system is integrated by classical RK4 in time, the force read on the fine
grid at t, t + h/2 and t + h as in :func:`bayesnsi.simulate.simulate_response`. It is independent of
the identification's discretisation (:mod:`bayesnsi.models.hysteresis` integrates z exactly along
the sampled displacement): the tests check one against the other. The non-smooth ``|u̇|`` makes RK4
first order across velocity reversals; the fine step keeps that error small (measured in the tests).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from ..exceptions import InputDataError, ShapeError
from ..models.terms import Term
from .integrate import Response, _as_batch_force, _check_finite

__all__ = ["simulate_hysteretic_response"]


def simulate_hysteretic_response(
    M, C, K, force_dofs: Sequence[int], force_fine, fs_fine: float, decimation: int,
    terms: Sequence[Term] = (), coefficients=(), max_abs_state: float = 1e8,
) -> Response:
    """Integrate the equation of motion with Bouc-Wen elements (``boucwen`` terms) by RK4 (module notes).

    Parameters
    ----------
    M, C, K : array_like, shape (N, N)
        Mass, damping and stiffness matrices of the underlying linear system.
    force_dofs : sequence of int
        DOF (1-based) of each force channel.
    force_fine : array_like, shape (n_fine,), (n_fine, m) or (n_batch, n_fine, m)
        Forces on the fine grid at ``fs_fine``.
    fs_fine : float
        Rate of ``force_fine`` [Hz]; the RK4 step is ``2 / fs_fine``.
    decimation : int
        Output every ``decimation`` fine samples (even).
    terms : sequence of Term
        Nonlinear terms; those with memory (``boucwen``) are integrated as states, the others
        evaluated on the stage states.
    coefficients : array_like, shape (q,)
        Their coefficients λ.
    max_abs_state : float
        A displacement, velocity or z beyond this magnitude counts as divergence.

    Returns
    -------
    Response
        As :func:`bayesnsi.simulate.simulate_response`; ``nonlinear_force`` includes the λ z forces,
        system at rest and z = 0 at t = 0.

    Raises
    ------
    ShapeError, InputDataError
        For inconsistent sizes, DOFs or an odd decimation.
    UnstableModelError
        When the state leaves ``max_abs_state``.
    """
    M, C, K = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (M, C, K))
    n = M.shape[0]
    if not (M.shape == C.shape == K.shape == (n, n)):
        raise ShapeError(f"M, C, K must be square and of one size, got {M.shape}, {C.shape}, {K.shape}")
    force, batched = _as_batch_force(force_fine)
    n_batch, n_fine, m = force.shape
    dofs = [int(d) for d in np.atleast_1d(force_dofs)]
    if len(dofs) != m or any(not 1 <= d <= n for d in dofs):
        raise InputDataError(f"force_dofs {dofs} must name one DOF in 1..{n} per force channel ({m})")
    if isinstance(decimation, bool) or int(decimation) != decimation or decimation < 2 or decimation % 2:
        raise InputDataError(f"decimation must be an even integer >= 2, got {decimation!r}")
    terms, coefs = tuple(terms), np.atleast_1d(np.asarray(coefficients, dtype=float))
    if len(coefs) != len(terms):
        raise ShapeError(f"{len(terms)} terms but {len(coefs)} coefficients")
    if any(max(t.dofs) > n for t in terms):
        raise InputDataError(f"a term reads or acts on a DOF beyond the model's {n} DOFs")
    m_inv = np.linalg.inv(M)
    F = np.zeros((n, m))
    F[np.array(dofs) - 1, np.arange(m)] = 1.0
    memory = [k for k, t in enumerate(terms) if t.expr.memory is not None]
    static = [k for k, t in enumerate(terms) if t.expr.memory is None]
    L = np.stack([t.location_vector(n) for t in terms], axis=1) if terms else np.zeros((n, 0))
    shapes = [s_ for k in memory if (s_ := terms[k].expr.memory) is not None]
    arguments = [a for k in memory if (a := terms[k].expr.memory_argument) is not None]
    q_m = len(shapes)
    unit = np.eye(n)
    rates = np.array([np.asarray(argument(unit, unit), dtype=np.float64) for argument in arguments])
    rates = rates.reshape(q_m, n)  # u̇_j = rates[j] · ẇ: the arguments are linear in the displacements
    # the augmented state y = [w; ẇ; z] obeys ẏ = A y + B f + (static terms) + (the z's nonlinear rates)
    size = 2 * n + q_m
    A = np.zeros((size, size))
    A[:n, n : 2 * n] = np.eye(n)
    A[n : 2 * n, :n], A[n : 2 * n, n : 2 * n] = -m_inv @ K, -m_inv @ C
    A[n : 2 * n, 2 * n :] = -m_inv @ (L[:, memory] * coefs[memory])
    A[2 * n :, n : 2 * n] = rates  # the u̇ of ż = u̇ - β |u̇| |z|^(n-1) z - γ u̇ |z|^n
    B = np.zeros((size, m))
    B[n : 2 * n] = m_inv @ F
    gain_static = -m_inv @ (L[:, static] * coefs[static])
    functions = [terms[k].expr.function for k in static]
    beta = np.array([[s_.beta] for s_ in shapes])
    gamma = np.array([[s_.gamma] for s_ in shapes])
    exponent = np.array([[s_.n] for s_ in shapes])
    linear_law = bool(np.all(exponent == 1.0))

    def slope(y, forcing):
        """ẏ of the augmented state (``forcing`` = B f)."""
        out = A @ y + forcing
        w, v = y[:n], y[n : 2 * n]
        if functions:
            out[n : 2 * n] += gain_static @ np.array([np.broadcast_to(fn(w, v), (y.shape[1],)) for fn in functions])
        if q_m:
            z, u_dot = y[2 * n :], rates @ v
            magnitude = np.abs(z) if linear_law else np.abs(z) ** exponent
            signed = z if linear_law else np.sign(z) * magnitude  # |z|^(n-1) z
            out[2 * n :] -= beta * np.abs(u_dot) * signed + gamma * u_dot * magnitude
        return out

    h = 2.0 / float(fs_fine)
    n_out = (n_fine - 1) // int(decimation) + 1
    per_out = int(decimation) // 2
    y = np.zeros((size, n_batch))
    states = np.empty((n_out, size, n_batch))
    states[0] = y
    forcing = np.einsum("sm,bkm->ksb", B, force)  # (n_fine, size, n_batch): B f on the fine grid
    start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore"):
        for out in range(1, n_out):
            for sub in range(per_out):
                step = (out - 1) * per_out + sub
                f0, fh, f1 = forcing[2 * step], forcing[2 * step + 1], forcing[2 * step + 2]
                k1 = slope(y, f0)
                k2 = slope(y + h / 2 * k1, fh)
                k3 = slope(y + h / 2 * k2, fh)
                k4 = slope(y + h * k3, f1)
                y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            states[out] = y
            if out % 256 == 0 or out == n_out - 1:
                _check_finite(states, max(out - 255, 1), out, max_abs_state, decimation / fs_fine)
    elapsed = time.perf_counter() - start
    x_all, v_all, z_all = states[:, :n], states[:, n : 2 * n], states[:, 2 * n :]  # (n_out, ., n_batch)
    f_out = force[:, :: int(decimation)][:, :n_out]  # (n_batch, n_out, m)
    nl = np.zeros((n_out, n, n_batch))
    for j, k in enumerate(memory):
        nl += coefs[k] * L[:, k][None, :, None] * z_all[:, j][:, None, :]
    for k in static:
        xs, vs = x_all.transpose(1, 0, 2), v_all.transpose(1, 0, 2)  # DOF-major (n, n_out, n_batch)
        nl += coefs[k] * L[:, k][None, :, None] * np.asarray(terms[k].expr.function(xs, vs))[:, None, :]
    applied = np.einsum("nm,bkm->knb", F, f_out)
    acc = np.einsum("ij,kjb->kib", m_inv, applied - np.einsum("ij,kjb->kib", C, v_all)
                    - np.einsum("ij,kjb->kib", K, x_all) - nl)

    def arranged(arr):  # (n_out, n, n_batch) -> (n_batch, n_out, n)
        res = np.ascontiguousarray(arr.transpose(2, 0, 1))
        return res if batched else res[0]

    return Response(
        displacement=arranged(x_all), velocity=arranged(v_all), acceleration=arranged(acc),
        nonlinear_force=arranged(nl), force=np.ascontiguousarray(f_out if batched else f_out[0]),
        fs=float(fs_fine) / int(decimation), step=h, n_steps=(n_out - 1) * per_out, elapsed_s=elapsed,
    )
