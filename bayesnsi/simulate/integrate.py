"""Fixed-step RK4 simulation of the nonlinear equation of motion (docs/method.md §1, Eqs. 5-7).

    M ẅ + C ẇ + K w + Σ_i λ_i l_i n_i(w, ẇ) = F f(t)

The force is read exactly from a fine, band-limited grid (docs/method.md §10: no hold between samples):
the RK4 step is ``h = 2 / fs_fine`` so that its stages at t, t + h/2 and t + h fall on fine
samples. Many independent realisations (a leading batch dimension) advance in one time loop.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import InputDataError, ShapeError, UnstableModelError
from ..models.terms import Term, nonlinear_force
from ._fixed_order import inverse, product, product_into
from .rk4 import rk4_maps

__all__ = ["Response", "simulate_response", "add_output_noise"]

_CHUNK_OUTPUTS = 2048  # output samples per chunk of precomputed force terms ...
_CHUNK_FLOATS = 2**22  # ... but at most this many floats (32 MiB) of them


@dataclass(frozen=True, eq=False, repr=False)
class Response:
    """Simulated response at the output rate.

    Arrays have shape ``(n_samples, n_dofs)`` for a single realisation, or
    ``(n_batch, n_samples, n_dofs)`` when the force had a batch dimension. Column ``k - 1``
    is DOF ``k``. Sample ``j`` is at time ``j / fs``.

    Attributes
    ----------
    displacement : ndarray
        w [m] (or rad for rotational DOFs).
    velocity : ndarray
        ẇ [m/s].
    acceleration : ndarray
        ẅ [m/s²], from the equation of motion at the output instants.
    nonlinear_force : ndarray
        Σ λ_i l_i n_i(w, ẇ) [N] at the output instants (zero without terms).
    force : ndarray, shape ([n_batch,] n_samples, m)
        The applied forces f(t) at the output instants [N].
    fs : float
        Output sampling frequency [Hz] (``fs_fine / decimation``).
    step : float
        RK4 step h [s].
    n_steps : int
        Number of RK4 steps taken.
    elapsed_s : float
        Wall time of the time loop [s].
    """

    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    nonlinear_force: np.ndarray
    force: np.ndarray
    fs: float
    step: float
    n_steps: int
    elapsed_s: float

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(self, displacement=self.displacement, fs=self.fs, step=self.step, n_steps=self.n_steps)

    @property
    def n_samples(self) -> int:
        """Number of output samples."""
        return self.displacement.shape[-2]

    @property
    def time(self) -> np.ndarray:
        """Output instants [s], shape (n_samples,)."""
        return np.arange(self.n_samples) / self.fs

    @property
    def time_per_step_s(self) -> float:
        """Wall time per RK4 step [s] (all realisations of a batch together)."""
        return self.elapsed_s / max(self.n_steps, 1)


def simulate_response(
    M,
    C,
    K,
    force_dofs: Sequence[int],
    force_fine,
    fs_fine: float,
    decimation: int,
    terms: Sequence[Term] = (),
    coefficients=(),
    x0=None,
    v0=None,
    max_abs_state: float = 1e8,
) -> Response:
    """Integrate ``M ẅ + C ẇ + K w + Σ λ_i l_i n_i(w, ẇ) = F f(t)`` by fixed-step RK4.

    Parameters
    ----------
    M, C, K : array_like, shape (N, N)
        Mass [kg], damping [N s/m] and stiffness [N/m] matrices of the underlying linear
        system; M must be invertible.
    force_dofs : sequence of int, length m
        DOF (1-based) at which each force channel acts (F has a one in row
        ``force_dofs[c] - 1`` of column ``c``).
    force_fine : array_like, shape (n_fine,), (n_fine, m) or (n_batch, n_fine, m)
        Forces [N] on the fine grid at ``fs_fine`` (e.g. :attr:`Excitation.fine`). A leading
        batch dimension simulates independent realisations together.
    fs_fine : float
        Sampling frequency of ``force_fine`` [Hz]. The RK4 step is ``h = 2 / fs_fine``.
    decimation : int
        Output every ``decimation`` fine samples (an even number); output sample ``j`` is
        at ``t = j * decimation / fs_fine``, aligned with the coarse force samples when
        ``decimation`` equals the oversampling factor.
    terms : sequence of Term
        Nonlinear terms n_i with their locations l_i (paper Eq. 6).
    coefficients : array_like, shape (q,)
        Coefficients λ_i.
    x0, v0 : array_like, shape (N,) or (n_batch, N), optional
        Initial displacement and velocity; zero by default.
    max_abs_state : float
        The state is declared exploding when any |w| or |ẇ| exceeds this (SI units).

    Returns
    -------
    Response

    Raises
    ------
    UnstableModelError
        If the state becomes non-finite or exceeds ``max_abs_state``; the message gives the
        time and realisation.

    Notes
    -----
    With the state z = [w; ẇ], ż = A z + b(t) + G n(z) where
    A = [[0, I], [-M⁻¹K, -M⁻¹C]], b = [0; M⁻¹F f(t)] and G = [0; -M⁻¹ L diag(λ)]. Because
    RK4 is linear in A z and in the stage inputs, one step is evaluated exactly (up to
    rounding) as

        z_s = P_s z + c_s(t) + Σ_{j<s} H_sj n(z_j),   s = 1..4,
        z⁺  = R(hA) z + d(t) + Σ_j W_j n(z_j),

    with matrices precomputed once and the force contributions c_s, d precomputed for whole
    chunks of steps; the loop then costs one matrix product and the q term evaluations per
    stage. The force enters at t, t + h/2 (stages 2 and 3) and t + h exactly as sampled on
    the fine grid. RK4 is stable for |h s| < 2.78 (s a pole) and its relative frequency error
    is about (ωh)⁴/120 (:func:`rk4_modal_error`). A non-smooth term such as sign(ẇ) makes
    the method first-order accurate across its switches.

    Cost (one core, numpy only): products in a fixed order (``_fixed_order.py``, a record the same on
    every CPU) cost 2x BLAS's for the two-DOF case and the beam, 1.2x for the twin (10, 18, 33 µs per
    step with BLAS); a batch of 20 costs 2.3 times one. ``Response.time_per_step_s`` reports it.
    """
    M, C, K = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (M, C, K))
    n = M.shape[0]
    if not (M.shape == C.shape == K.shape == (n, n)):
        raise ShapeError(f"M, C, K must be square and of one size, got {M.shape}, {C.shape}, {K.shape}")
    force, batched = _as_batch_force(force_fine)
    n_batch, n_fine, m = force.shape
    dofs = tuple(int(d) for d in np.atleast_1d(force_dofs))
    if len(dofs) != m:
        raise ShapeError(f"force_dofs lists {len(dofs)} DOFs but force_fine has {m} channels")
    if any(d < 1 or d > n for d in dofs):
        raise InputDataError(f"force_dofs must lie in 1..{n}, got {dofs}")
    fs_fine = float(fs_fine)
    if not (np.isfinite(fs_fine) and fs_fine > 0):
        raise InputDataError(f"fs_fine must be a positive number of Hz, got {fs_fine!r}")
    if isinstance(decimation, bool) or int(decimation) != decimation or decimation < 2 or decimation % 2:
        raise InputDataError(
            f"decimation must be an even integer >= 2 (each RK4 step spans two fine samples), got {decimation!r}"
        )
    decimation = int(decimation)
    terms = tuple(terms)
    coefs = np.atleast_1d(np.asarray(coefficients, dtype=float)) if terms else np.zeros(0)
    if len(coefs) != len(terms):
        raise ShapeError(f"{len(terms)} terms but {len(coefs)} coefficients")
    for term in terms:
        if max(term.dofs) > n:
            raise InputDataError(f"term {term.name} reads or acts on DOF {max(term.dofs)} but the model has {n} DOFs")
        if term.expr.memory is not None:
            raise InputDataError(f"term {term.name} has memory: simulate it with simulate_hysteretic_response")

    h = 2.0 / fs_fine
    n_out = (n_fine - 1) // decimation + 1
    steps_per_out = decimation // 2
    n_steps = (n_out - 1) * steps_per_out

    # --- matrices of the first-order system ------------------------------------------
    try:
        m_inv = inverse(M)
    except np.linalg.LinAlgError:
        raise InputDataError("M is singular; every DOF needs mass (or inertia)") from None
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -product(m_inv, K)
    A[n:, n:] = -product(m_inv, C)
    F = np.zeros((n, m))
    F[np.array(dofs) - 1, np.arange(m)] = 1.0
    B = np.vstack([np.zeros((n, m)), product(m_inv, F)])  # (2n, m)
    q = len(terms)
    L = np.stack([t.location_vector(n) for t in terms], axis=1) if q else np.zeros((n, 0))
    G = np.vstack([np.zeros((n, q)), -product(m_inv, L) * coefs])  # (2n, q)

    stage_z, stage_u, final_z, final_u = rk4_maps(A, h)
    # rows: [final (2n); stage 1 (2n); stage 2; stage 3; stage 4]
    omega = np.vstack([final_z] + stage_z)  # (10n, 2n)
    maps_u = [final_u] + stage_u  # each: list of 4 (2n, 2n) blocks (inputs u1..u4)
    r_0 = np.vstack([product(mu[0], B) for mu in maps_u])  # force at t
    r_h = np.vstack([product(mu[1] + mu[2], B) for mu in maps_u])  # force at t + h/2
    r_1 = np.vstack([product(mu[3], B) for mu in maps_u])  # force at t + h
    H = [None] + [np.hstack([product(stage_u[s][j], G) for j in range(s)]) for s in (1, 2, 3)]
    W = np.hstack([product(final_u[j], G) for j in range(4)])  # (2n, 4q)
    functions = [_evaluator(t) for t in terms]

    # --- initial state --------------------------------------------------------------
    z = np.zeros((2 * n, n_batch))
    for idx, (name, value) in enumerate((("x0", x0), ("v0", v0))):
        if value is not None:
            arr = np.asarray(value, dtype=float)
            if arr.shape not in ((n,), (n_batch, n)):
                raise ShapeError(f"{name} must have shape ({n},) or ({n_batch}, {n}), got {arr.shape}")
            z[idx * n : (idx + 1) * n] = arr.T if arr.ndim == 2 else arr[:, None]

    states = np.empty((n_out, 2 * n, n_batch))
    states[0] = z
    maps = (omega, r_0, r_h, r_1, H, W)
    t_start = time.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        _march(states, force, maps, functions, n, steps_per_out, max_abs_state, decimation / fs_fine)
    elapsed = time.perf_counter() - t_start

    # --- outputs ------------------------------------------------------------------------
    x = states[:, :n].transpose(1, 2, 0)  # DOF-major (n, n_batch, n_out)
    v = states[:, n:].transpose(1, 2, 0)
    if q:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            nl = nonlinear_force(terms, coefs, x, v, n)
    else:
        nl = np.zeros_like(x)
    f_out = force[:, ::decimation][:, :n_out]  # (n_batch, n_out, m)
    applied = np.einsum("nm,bkm->nbk", F, f_out)
    balance = applied - np.einsum("ij,jbk->ibk", C, v) - np.einsum("ij,jbk->ibk", K, x) - nl
    acc = np.einsum("ij,jbk->ibk", m_inv, balance)

    def out(arr):  # (n, n_batch, n_out) -> (n_batch, n_out, n)
        res = np.ascontiguousarray(arr.transpose(1, 2, 0))
        return res if batched else res[0]

    return Response(
        displacement=out(x),
        velocity=out(v),
        acceleration=out(acc),
        nonlinear_force=out(nl),
        force=np.ascontiguousarray(f_out if batched else f_out[0]),
        fs=fs_fine / decimation,
        step=h,
        n_steps=n_steps,
        elapsed_s=elapsed,
    )


def _march(states, force, maps, functions, n, steps_per_out, limit, dt_out) -> None:
    """The RK4 time loop; fills ``states[1:]`` (shape (n_out, 2n, n_batch)) in place."""
    omega, r_0, r_h, r_1, H, W = maps
    n_out, rows, n_batch = states.shape
    q = len(functions)
    # preallocated buffers and views (no allocation inside the loop but the term values)
    ybuf = np.empty((5 * rows, n_batch))
    y_final = ybuf[:rows]
    y_stage = [ybuf[(s + 1) * rows : (s + 2) * rows] for s in range(4)]
    z_stage = [y_stage[0]] + [np.empty((rows, n_batch)) for _ in range(3)]
    xv = [(zb[:n], zb[n:]) for zb in z_stage]
    n_stack = np.zeros((4 * q, n_batch))
    n_prev = [n_stack[:0]] + [n_stack[: s * q] for s in (1, 2, 3)]  # terms of the stages before stage s
    tmp = np.empty((rows, n_batch))
    work = (np.empty((rows, n_batch)), np.empty((rows, n_batch)))  # states between outputs
    final_z = omega[:rows]
    # scratch of the fixed-order products (_fixed_order.py: the same bits on every CPU)
    scratch_final, scratch_omega, scratch_w, *scratch_h = (
        np.empty((n_batch, *a.shape)) for a in (final_z, omega, W, *H[1:]))
    z = states[0]
    chunk = int(max(1, min(_CHUNK_OUTPUTS, _CHUNK_FLOATS // (steps_per_out * 5 * rows * n_batch))))
    out = 1
    while out < n_out:
        stop = min(out + chunk, n_out)
        first, last = (out - 1) * steps_per_out, (stop - 1) * steps_per_out  # steps first..last-1
        f0 = force[:, 2 * first : 2 * last : 2]
        fh = force[:, 2 * first + 1 : 2 * last : 2]
        f1 = force[:, 2 * first + 2 : 2 * last + 1 : 2]
        # force contributions to the update and every stage, shape (chunk steps, 5 rows, n_batch)
        pre = np.einsum("rm,bkm->krb", r_0, f0)
        pre += np.einsum("rm,bkm->krb", r_h, fh)
        pre += np.einsum("rm,bkm->krb", r_1, f1)
        k = 0
        for idx in range(out, stop):
            for sub in range(steps_per_out):
                target = states[idx] if sub == steps_per_out - 1 else work[sub % 2]
                if q == 0:
                    product_into(final_z, z, target, scratch_final)
                    target += pre[k, :rows]
                else:
                    product_into(omega, z, ybuf, scratch_omega)
                    ybuf += pre[k]
                    x_s, v_s = xv[0]
                    for j, fn in enumerate(functions):
                        n_stack[j] = fn(x_s, v_s)
                    for s in (1, 2, 3):
                        product_into(H[s], n_prev[s], tmp, scratch_h[s - 1])
                        np.add(y_stage[s], tmp, out=z_stage[s])
                        x_s, v_s = xv[s]
                        for j, fn in enumerate(functions):
                            n_stack[s * q + j] = fn(x_s, v_s)
                    product_into(W, n_stack, tmp, scratch_w)
                    np.add(y_final, tmp, out=target)
                z = target
                k += 1
        _check_finite(states, out, stop - 1, limit, dt_out)
        out = stop


def add_output_noise(signal, percent: float, rng=None) -> np.ndarray:
    """Add Gaussian measurement noise proportional to each channel's standard deviation.

    Parameters
    ----------
    signal : array_like
        Noise-free signal of shape (n_samples,), (n_samples, n_channels) or
        (n_batch, n_samples, n_channels); not modified.
    percent : float
        Noise level: the noise of each channel has standard deviation ``percent / 100``
        times that channel's standard deviation over time (docs/method.md §8: "2 % output noise (of
        each signal's std)").
    rng : int, numpy.random.Generator or None
        Source of randomness (:func:`numpy.random.default_rng`).

    Returns
    -------
    ndarray
        A new array of the same shape.
    """
    arr = np.asarray(signal, dtype=float)
    percent = float(percent)
    if not (np.isfinite(percent) and percent >= 0):
        raise InputDataError(f"noise percent must be a non-negative number, got {percent!r}")
    axis = 0 if arr.ndim == 1 else -2
    std = arr.std(axis=axis, keepdims=True)
    noise = np.random.default_rng(rng).standard_normal(arr.shape)
    return arr + noise * std * (percent / 100.0)


def _evaluator(term: Term):
    """Fast scalar-free evaluator of a term's basis function on DOF-major (x, v) views.

    Uses :attr:`Expression.function`, the compiled closure (``Term.evaluate`` adds an
    ``errstate`` context and a copy per call, which would dominate the RK4 loop); the loop sets
    ``errstate`` once.
    """
    return term.expr.function


def _as_batch_force(force_fine):
    arr = np.asarray(force_fine, dtype=float)
    if arr.ndim == 1:
        arr, batched = arr[None, :, None], False
    elif arr.ndim == 2:
        arr, batched = arr[None], False
    elif arr.ndim == 3:
        batched = True
    else:
        raise ShapeError(f"force_fine must have shape (n_fine, m) or (n_batch, n_fine, m), got {arr.shape}")
    if arr.shape[1] < 3:
        raise ShapeError(f"force_fine needs at least 3 fine samples, got {arr.shape[1]}")
    if not np.all(np.isfinite(arr)):
        raise InputDataError("force_fine holds NaN or Inf values")
    return arr, batched


def _check_finite(states, first: int, last: int, limit: float, dt_out: float) -> None:
    block = states[first : last + 1]
    bad = ~(np.abs(block) <= limit)  # also catches NaN
    if bad.any():
        k, _, b = np.argwhere(bad)[0]
        t = (first + k) * dt_out
        raise UnstableModelError(
            f"the simulated state became non-finite or exceeded {limit:g} (SI units) by t = {t:.6g} s "
            f"(realisation {b}); the model may be unstable for this input: use a smaller step "
            "(larger oversampling), a lower force level, or check the signs of the coefficients"
        )
