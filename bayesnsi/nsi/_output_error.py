"""Output-error refinement of B, D and x₀ with A, C fixed (docs/method.md §3 and 10).

``y_k = C A^k x₀ + Σ_{τ<k} C A^{k-1-τ} B u_τ + D u_k`` is linear in (x₀, B, D). In modal
coordinates (``A = V Λ V⁻¹``) every regressor of every output channel is a fixed real linear
combination of a few basis signals: the real and imaginary parts of each input filtered by each
mode (``z_{k+1} = λ z_k + u_k``), of the free responses ``λ^k``, and the inputs themselves.
So one Gram matrix of those basis signals, accumulated in chunks (the recursive filters carry
their state across chunks), gives the normal equations of all outputs: time O(N (nm)²), memory
independent of N.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import blas as _blas

from ..noise import white_noise_std
from .statespace import modal_filter_step

__all__ = ["refine_output_error", "refine_poles"]

_CHUNK = 8192


def _basis_gram(lam: np.ndarray, u: np.ndarray, y: np.ndarray):
    """Gram of the basis signals ``S = [Re F, Im F, Re P, Im P, u]`` and ``Sᵀ y``.

    ``F[:, c·n + p]`` is input c filtered by mode p (zero initial state), ``P[:, p] = λ_p^k``.
    """
    n, m = len(lam), u.shape[1]  # n: modes kept
    width = 2 * n * m + 2 * n + m
    gram = np.zeros((width, width), order="F")
    cross = np.zeros((width, y.shape[1]))
    state = [[None] * n for _ in range(m)]  # per input and mode, carried across chunks
    step_powers = np.exp(np.arange(_CHUNK)[:, None] * np.log(lam.astype(complex))[None, :])
    chunk_start = np.ones(n, dtype=complex)  # λ^start
    basis = np.empty((_CHUNK, width), order="F")
    for start in range(0, len(u), _CHUNK):
        size = min(_CHUNK, len(u) - start)
        uc = u[start : start + size]
        for c in range(m):
            column = np.ascontiguousarray(uc[:, c])
            for p, lp in enumerate(lam):
                filtered, state[c][p] = modal_filter_step(complex(lp), column, state[c][p])
                basis[:size, c * n + p] = filtered.real
                basis[:size, n * m + c * n + p] = filtered.imag if np.iscomplexobj(filtered) else 0.0
        powers = step_powers[:size] * chunk_start
        basis[:size, 2 * n * m : 2 * n * m + n] = powers.real
        basis[:size, 2 * n * m + n : 2 * n * m + 2 * n] = powers.imag
        basis[:size, 2 * n * m + 2 * n :] = uc
        chunk_start = chunk_start * lam**size
        view = basis[:size]
        gram = _blas.dsyrk(1.0, view, beta=1.0, c=gram, trans=1, lower=0, overwrite_c=1)  # Sᵀ S, upper
        cross += view.T @ y[start : start + size]
    return np.triu(gram) + np.triu(gram, 1).T, cross


def refine_output_error(A, C, u, y, dt, zero_feedthrough=True, output_weights=None):
    """Least-squares B, D, x₀ minimising the simulation error with A, C fixed.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (l, n)
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, l)
    dt : float
        Sampling interval [s] (unused by the algebra; kept for a uniform signature).
    zero_feedthrough : bool
        Impose D = 0 (displacement outputs).
    output_weights : ndarray, shape (l,), optional
        Weight of each output channel's squared error (e.g. 1/var(y_o) so channels of different
        size count alike); default 1.

    Returns
    -------
    B : ndarray, shape (n, m)
    D : ndarray, shape (l, m)
    x0 : ndarray, shape (n,)
    """
    n, m, l = A.shape[0], u.shape[1], y.shape[1]
    lam_all, vec = np.linalg.eig(A)
    vinv_all = np.linalg.inv(vec)
    cm_all = C @ vec
    # A real system's complex modes come in conjugate pairs whose contributions are complex
    # conjugates: keep one of each pair with weight 2 (halves the basis).
    keep = lam_all.imag > 0
    real = np.abs(lam_all.imag) <= 1e-12 * np.abs(lam_all)
    keep |= real
    factor = np.where(real[keep], 1.0, 2.0)
    lam, vinv, cm = lam_all[keep], vinv_all[keep] * factor[:, None], cm_all[:, keep]
    gram, cross = _basis_gram(lam, np.asarray(u, dtype=float), np.asarray(y, dtype=float))
    n_modes = len(lam)
    n_b, n_d = n * m, (0 if zero_feedthrough else l * m)
    size = n_b + n_d + n
    width = gram.shape[0]
    normal = np.zeros((size, size))
    rhs = np.zeros(size)
    for o in range(l):
        # Regressor of output o = basis @ weights: Re(F_c w) = Re(F_c) Re(w) - Im(F_c) Im(w).
        weights = np.zeros((width, size))
        modal = cm[o][:, None] * vinv  # (modes, n states): d y_o / d B[r, c] per mode p
        k = n_modes
        for c in range(m):
            cols = np.arange(n) * m + c  # parameter index r*m + c <-> B[r, c]
            weights[c * k : (c + 1) * k, cols] = modal.real
            weights[k * m + c * k : k * m + (c + 1) * k, cols] = -modal.imag
        free = 2 * k * m
        weights[free : free + k, n_b + n_d :] = modal.real
        weights[free + k : free + 2 * k, n_b + n_d :] = -modal.imag
        if n_d:
            weights[free + 2 * k + np.arange(m), n_b + o * m + np.arange(m)] = 1.0
        w = 1.0 if output_weights is None else output_weights[o]
        normal += w * (weights.T @ gram @ weights)
        rhs += w * (weights.T @ cross[:, o])
    scale = np.sqrt(np.diag(normal))
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(normal / np.outer(scale, scale), rhs / scale, rcond=None)[0] / scale
    B = theta[:n_b].reshape(n, m)
    D = np.zeros((l, m)) if zero_feedthrough else theta[n_b : n_b + n_d].reshape(l, m)
    x0 = theta[n_b + n_d :]
    return B, D, x0


# --------------------------------------------------------------------------------------------
# Pole refinement (docs/method.md §3 and 10): output error on band-passed data, variable projection
# --------------------------------------------------------------------------------------------


def _pole_basis_gram(lam, refine, u, y, skip):
    """Gram of ``[S, T]`` and ``[S, T]ᵀ y`` for the pole-residue output-error model.

    ``S``: per eigenvalue p (one of each conjugate pair, or real) the inputs filtered by
    ``1/(z - λ_p)`` and the free response ``λ_p^k`` (real and imaginary parts for complex p).
    ``T``: for the refined p, their derivatives with respect to ``λ_p``: the filtered inputs
    filtered once more (``∂F/∂λ = F/(z - λ)``) and ``k λ_p^{k-1}``. Samples ``skip`` from either
    end are left out (transients of the band-pass prefilter).
    """
    from scipy import signal as _signal  # when needed: 0.4 s to import
    n_samples, m = u.shape
    complex_mode = np.abs(lam.imag) > 0
    s_cols, col = [], 0
    for p in range(len(lam)):
        width = 2 if complex_mode[p] else 1
        s_cols.append((col, width))
        col += width * (m + 1)
    n_s = col
    t_cols = {}
    for p in np.flatnonzero(refine):
        t_cols[p] = col
        col += 2 * (m + 1)
    gram = np.zeros((col, col), order="F")
    cross = np.zeros((col, y.shape[1]))
    state_f = np.zeros((len(lam), m), dtype=complex)
    state_h = np.zeros((len(lam), m), dtype=complex)
    chunk_start = np.ones(len(lam), dtype=complex)
    basis = np.empty((_CHUNK, col), order="F")
    for start in range(0, n_samples, _CHUNK):
        size = min(_CHUNK, n_samples - start)
        uc = u[start : start + size]
        steps = np.arange(size)
        for p, lp in enumerate(lam):
            first, width = s_cols[p]
            a = np.array([1.0, -lp], dtype=complex)
            powers = chunk_start[p] * np.exp(steps * np.log(complex(lp)))
            for c in range(m):
                filt, zf = _signal.lfilter([0.0, 1.0], a, uc[:, c].astype(complex), zi=state_f[p, c : c + 1])
                state_f[p, c] = zf[0]
                basis[:size, first + width * c] = filt.real
                if width == 2:
                    basis[:size, first + width * c + 1] = filt.imag
                if p in t_cols:
                    deriv, zh = _signal.lfilter([0.0, 1.0], a, filt, zi=state_h[p, c : c + 1])
                    state_h[p, c] = zh[0]
                    basis[:size, t_cols[p] + 2 * c] = deriv.real
                    basis[:size, t_cols[p] + 2 * c + 1] = deriv.imag
            basis[:size, first + width * m] = powers.real
            if width == 2:
                basis[:size, first + width * m + 1] = powers.imag
            if p in t_cols:
                deriv = (start + steps) * powers / lp
                basis[:size, t_cols[p] + 2 * m] = deriv.real
                basis[:size, t_cols[p] + 2 * m + 1] = deriv.imag
            chunk_start[p] *= lp**size
        lo, hi = max(0, skip - start), min(size, n_samples - skip - start)
        if hi <= lo:
            continue
        view = basis[lo:hi]
        gram = _blas.dsyrk(1.0, view, beta=1.0, c=gram, trans=1, lower=0, overwrite_c=1)
        cross += view.T @ y[start + lo : start + hi]
    return np.triu(gram) + np.triu(gram, 1).T, cross, s_cols, t_cols, n_s


def _scaled_solve(gram, rhs):
    scale = np.sqrt(np.abs(np.diag(gram)))
    scale[scale == 0] = 1.0
    sol = np.linalg.lstsq(gram / np.outer(scale, scale), rhs / scale[:, None], rcond=1e-13)[0]
    return sol / scale[:, None]


def refine_poles(
    A,
    u,
    y,
    dt,
    band_hz,
    noise_std=None,
    iterations: int = 20,
    prefilter_order: int = 4,
):
    """Refine the poles of A in a band by output error on band-passed data (docs/method.md §3 and 10).

    The subspace estimate of A is consistent but not efficient: with output noise its damping
    ratios scatter by several percent even when the inputs are exact. This step minimises
    the output error of a pole-residue model

        y_o(k) = Σ_p Re[ Σ_c ρ_{o,c,p} F_{c,p}(k) + γ_{o,p} λ_p^k ],   F_{c,p} = u_c / (z - λ_p)

    over the poles λ_p (Gauss-Newton / Levenberg-Marquardt on the continuous-time poles), the
    residues (ρ, γ) being solved by linear least squares inside (variable projection; Golub &
    Pereyra 2003, Kaufman's Jacobian). All products come from one Gram matrix of the basis
    signals per iteration (memory independent of N). Inputs and outputs are band-passed by the
    same zero-phase Butterworth filter first (an LTI prefilter keeps y = G u): the fit then
    weighs the band, and leaves out the low-frequency part of the residual, which can be
    dominated by the measurement noise propagated through the nonlinear inputs (errors in
    variables, :mod:`._eiv`).
    Channels are weighted by ``1/noise_std²`` (maximum likelihood for white output noise).

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Discrete-time state matrix from the subspace step.
    u : ndarray, shape (N, m)
        Extended input.
    y : ndarray, shape (N, l)
        Measured outputs.
    dt : float
        Sampling interval [s].
    band_hz : (float, float)
        Prefilter band; poles with ``band[0]/1.5 < f_n < 1.5·band[1]`` are refined, the others
        kept (they stay in the model of the band-passed data).
    noise_std : ndarray, shape (l,), optional
        Output-noise std per channel (weights); default
        :func:`bayesnsi.nsi._noise.white_noise_std` of ``y``.
    iterations : int
        Largest number of Gauss-Newton iterations (stops when the poles move < 1e-7 relative).
    prefilter_order : int
        Butterworth order of the band-pass prefilter (applied forwards and backwards).

    Returns
    -------
    A_refined : ndarray, shape (n, n)
        ``V diag(λ_refined) V⁻¹`` (real): the eigenvectors of ``A``, hence the mode shapes seen
        by C, are kept.
    info : dict
        ``cost_initial``, ``cost`` (weighted residual sum of squares), ``iterations``,
        ``refined`` (number of refined modes), and (when a mode was refined) the pole-residue
        model of the band-passed data: ``eigenvalue_index`` (indices into ``eig(A)`` of one of
        each conjugate pair and of the real eigenvalues), ``eigenvalues`` (refined, same order),
        ``refined_mask``, ``residues`` (complex, (modes, l, m + 1): ρ for each input, then γ of
        the free response, in output units). The subspace C does not match the refined poles;
        ``NSIOptions(c_method="prediction-error")`` re-fits C (measurements in
        ``docs/measurements.md``).
    """
    from scipy import signal as _signal  # when needed: 0.4 s to import
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    lo, hi = (float(b) for b in band_hz)
    nyquist = 0.5 / dt
    if not 0 < lo < hi:
        raise ValueError(f"refinement band must satisfy 0 < low < high, got {band_hz}")
    hi = min(hi, 0.95 * nyquist)
    sigma = white_noise_std(y) if noise_std is None else np.asarray(noise_std, dtype=float)
    sigma = np.where(sigma > 0, sigma, y.std(axis=0) + 1e-300)
    sos = _signal.butter(prefilter_order, [lo, hi], btype="band", fs=1.0 / dt, output="sos")
    u_f = _signal.sosfiltfilt(sos, u, axis=0)
    y_f = _signal.sosfiltfilt(sos, y, axis=0) / sigma
    skip = int(min(np.ceil(4.0 / (lo * dt)), len(y) // 10))

    lam_all, vec = np.linalg.eig(A)
    upper = lam_all.imag >= 0
    index = np.flatnonzero(upper)  # one of each conjugate pair, and the real eigenvalues
    lam = lam_all[index].astype(complex)
    with np.errstate(divide="ignore"):
        s_cont = np.log(lam) / dt
    freq = np.abs(s_cont) / (2 * np.pi)
    refine = (np.abs(lam.imag) > 0) & (freq > lo / 1.5) & (freq < 1.5 * hi) & (np.abs(lam) < 1)
    info: dict[str, Any] = {"refined": int(refine.sum()), "iterations": 0}
    if not refine.any():
        info.update(cost_initial=np.nan, cost=np.nan)
        return np.array(A, dtype=float), info
    m = u.shape[1]
    total = float(np.sum(y_f[skip : len(y_f) - skip] ** 2))
    refined = np.flatnonzero(refine)

    def evaluate(poles):
        gram, cross, s_cols, t_cols, n_s = _pole_basis_gram(poles, refine, u_f, y_f, skip)
        beta = _scaled_solve(gram[:n_s, :n_s], cross[:n_s])
        return total - float(np.sum(cross[:n_s] * beta)), (gram, cross, s_cols, t_cols, n_s, beta)

    cost, state = evaluate(lam)
    info["cost_initial"] = cost
    damping = 1e-3
    for it in range(iterations):
        gram, cross, s_cols, t_cols, n_s, beta = state
        g_ss, g_ts, g_tt = gram[:n_s, :n_s], gram[n_s:, :n_s], gram[n_s:, n_s:]
        schur = g_tt - g_ts @ _scaled_solve(g_ss, g_ts.T)
        t_res = cross[n_s:] - g_ts @ beta  # Tᵀ r per output
        n_par = 2 * len(refined)
        jtj, grad = np.zeros((n_par, n_par)), np.zeros(n_par)
        for o in range(y.shape[1]):
            mix = np.zeros((gram.shape[0] - n_s, n_par))
            for j, p in enumerate(refined):
                first, _ = s_cols[p]
                t0 = t_cols[p] - n_s
                for a, direction in enumerate((lam[p] * dt, 1j * lam[p] * dt)):  # ∂λ/∂Re s, ∂λ/∂Im s
                    for c in range(m + 1):
                        rho = (beta[first + 2 * c, o] - 1j * beta[first + 2 * c + 1, o]) * direction
                        mix[t0 + 2 * c, 2 * j + a] = rho.real
                        mix[t0 + 2 * c + 1, 2 * j + a] = -rho.imag
            jtj += mix.T @ schur @ mix
            grad += mix.T @ t_res[:, o]
        diag = np.diag(jtj).copy()
        diag[diag <= 0] = 1.0
        accepted = False
        while damping < 1e8:
            step = np.linalg.solve(jtj + damping * np.diag(diag), grad)
            trial = lam.copy()
            trial[refined] = np.exp((s_cont[refined] + step[0::2] + 1j * step[1::2]) * dt)
            if np.all(np.abs(trial) < 1) and np.all(trial[refined].imag > 0):
                new_cost, new_state = evaluate(trial)
                if new_cost <= cost:
                    accepted = True
                    break
            damping *= 10.0
        info["iterations"] = it + 1
        if not accepted:
            break
        relative = np.max(np.abs(step[0::2] + 1j * step[1::2]) / np.abs(s_cont[refined]))
        lam, cost, state = trial, new_cost, new_state
        s_cont = np.log(lam) / dt
        damping = max(damping / 10.0, 1e-6)
        if relative < 1e-7:
            break
    info["cost"] = cost
    beta, s_cols = state[5], state[2]
    residues = np.zeros((len(lam), y.shape[1], m + 1), dtype=complex)
    for pole, (first, width) in enumerate(s_cols):
        for c in range(m + 1):
            if width == 2:
                residues[pole, :, c] = (beta[first + 2 * c] - 1j * beta[first + 2 * c + 1]) * sigma
            else:
                residues[pole, :, c] = beta[first + c] * sigma
    info.update(eigenvalue_index=index, eigenvalues=lam, residues=residues, refined_mask=refine)
    new_all = lam_all.astype(complex).copy()
    new_all[index] = lam
    pair = np.flatnonzero(lam_all.imag < 0)
    for p in pair:  # conjugate partner of each refined upper eigenvalue
        partner = index[np.argmin(np.abs(lam_all[index] - np.conj(lam_all[p])))]
        new_all[p] = np.conj(new_all[partner])
    A_new = (vec * new_all) @ np.linalg.inv(vec)
    return A_new.real.copy(), info
