"""Frequency-domain subspace identification of the extended-input system (docs/method.md §11, FNSI).

McKelvey, Akçay and Ljung (IEEE TAC 41, 1996) with the noise weighting of Pintelon (2002), on
the lines of a periodic record (Noël and Kerschen, MSSP 40, 2013). In periodic steady state a
model ``G(w) = D + C (w I - A)⁻¹ B`` relates the spectra exactly, ``Y(k) = G(w_k) U(k)``, on every
line k, with ``w_k = e^{jω_kΔt}`` for a discrete model or ``w_k = jω_k`` for a continuous one.
The continuous model is fitted (exact for the structure's FRF; a discrete one of the same order
is not) through the bilinear map ``w̃ = (ω0 + jω)/(ω0 - jω)`` that puts the lines on the unit
circle. Stacking ``w̃_k^0 .. w̃_k^{r-1}`` times Y(k) and U(k) over the lines gives
``𝒴 = O_r 𝒳 + Γ_r 𝒰`` with the extended observability matrix O_r, so the range of 𝒴 projected
off 𝒰 (real and imaginary parts as columns), whitened by the stacked noise covariance, is that
of O_r: A and C follow by shift invariance, B and D by weighted linear least squares on the same
lines; a variable-projection refinement of A and C (:func:`refine`) then minimises the weighted
misfit on the lines.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg

from ..exceptions import BlockRowsError, InputDataError
from ..signals import Signals
from ._aft import basis_spectra
from .periodic import excited_lines, period_dft

_SMOOTH_LINES = 9  # running median of the noise variance over this many lines (weights)


@dataclass(frozen=True)
class LineData:
    """Period-averaged spectra of the extended input and the outputs on the fitted lines."""

    lines: np.ndarray  # (M,) DFT line indices
    freqs_hz: np.ndarray  # (M,)
    z: np.ndarray  # (M,) e^{jωΔt}
    inputs: np.ndarray  # (M, m + q) complex: [F; -N]
    outputs: np.ndarray  # (M, l) complex
    output_cov: np.ndarray  # (M, l, l) noise covariance of the mean outputs
    n_periods: int
    excited: np.ndarray | None = None  # (M,) bool: the force excites the line (None: all do)
    rebuild: Callable | None = field(default=None, compare=False, repr=False)  # inputs from model outputs
    realisation: np.ndarray | None = None  # (M,) int: the realisation of each row (None: one realisation)

    @property
    def n_realisations(self) -> int:
        """Number of realisations whose lines are stacked (rows of the same frequencies, new phases)."""
        return 1 if self.realisation is None else int(self.realisation.max()) + 1

    def with_smoothed_basis(self, model_outputs: np.ndarray) -> LineData:
        """The same lines with the basis spectra evaluated on ``model_outputs`` (M, l) instead of the
        averaged displacement on the fitted lines (the rest of the spectrum as measured).

        A model that fits the lines to the noise level predicts the displacement there with far
        less noise than the period average; the basis functions built from it carry less
        errors-in-variables noise (benchmarks/fnsi.py: k3 scatter 0.31 -> 0.28 % over 20 seeds).
        """
        if self.rebuild is None:
            return self
        out = replace(self, inputs=self.rebuild(model_outputs))
        object.__setattr__(out, "_output_std", self.output_std)
        return out

    def excited_only(self) -> LineData:
        """The same data on the excited lines only (the subspace step: the unexcited ones have no force)."""
        if self.excited is None or self.excited.all():
            return self
        keep = self.excited
        return LineData(lines=self.lines[keep], freqs_hz=self.freqs_hz[keep], z=self.z[keep],
                        inputs=self.inputs[keep], outputs=self.outputs[keep], output_cov=self.output_cov[keep],
                        n_periods=self.n_periods, realisation=None if self.realisation is None else
                        self.realisation[keep])

    @property
    def output_std(self) -> np.ndarray:
        """Noise std of the averaged outputs per line and channel, smoothed over neighbouring lines."""
        cached = self.__dict__.get("_output_std")
        if cached is None:
            var = np.real(np.diagonal(self.output_cov, axis1=1, axis2=2))
            cached = np.empty_like(var)
            blocks = np.zeros(len(var), dtype=int) if self.realisation is None else self.realisation
            for r in np.unique(blocks):  # neighbouring lines of the same realisation
                cached[blocks == r] = np.sqrt(_smoothed(var[blocks == r]))
            object.__setattr__(self, "_output_std", cached)
        return cached


def line_data(signals: Signals, terms, velocity_method: str, band_hz, drop: int = 0) -> LineData:
    """Extended input and outputs averaged over the periods, on the excited lines inside the band.

    The basis functions are evaluated on the period-averaged time signals (velocity by exact
    spectral differentiation of the averaged displacement unless velocities are measured), so
    the noise they carry is that of the average (errors in variables reduced by the number of
    periods). :meth:`LineData.with_smoothed_basis` evaluates them again with the displacement on
    the fitted lines replaced by a model's output. With several ``signals.realisations`` each
    realisation's periods are averaged and its noise taken from its own period scatter; their
    lines are stacked as separate experiments at the same frequencies (rows ``r M .. (r+1) M - 1``
    of realisation r), every line from the first to the last line excited in any of them.
    """
    if signals.period is None:
        raise InputDataError(
            'the frequency route ([nsi] domain = "frequency") needs periodic data: give [data] period '
            "(samples per period), or Signals(period=...)"
        )
    parts = [_Realisation(one, terms, velocity_method, drop) for one in signals.realisation_records()]
    first = parts[0]
    freqs = first.omega / (2 * np.pi)
    mask = np.any([p.excited for p in parts], axis=0)
    if band_hz is not None:
        mask &= (freqs >= band_hz[0]) & (freqs <= band_hz[1])
    lines = np.flatnonzero(mask)
    if len(lines) >= 4:  # every line between the first and last excited one of the band: the empty ones
        lines = np.arange(lines[0], lines[-1] + 1)  # carry the nonlinear distortion (docs/method.md §11)
    if len(lines) < 4:
        raise InputDataError(
            f"only {len(lines)} excited line(s) inside the band {band_hz} Hz; widen [nsi] band_hz or check "
            "[data] period"
        )
    n_lines, several = len(lines), len(parts) > 1

    def rebuild(model_outputs):
        return np.concatenate([p.rebuild(lines, model_outputs[r * n_lines : (r + 1) * n_lines])
                               for r, p in enumerate(parts)])

    stack = lambda arrays: np.concatenate(arrays) if several else arrays[0]  # noqa: E731
    return LineData(
        lines=np.tile(lines, len(parts)), freqs_hz=np.tile(freqs[lines], len(parts)),
        z=np.tile(np.exp(1j * first.omega[lines] / signals.fs), len(parts)),
        inputs=stack([p.basis_spectra(p.x_mean, p.v_mean)[lines] for p in parts]),
        outputs=stack([p.x_mean[lines] for p in parts]), output_cov=stack([p.cov[lines] for p in parts]),
        n_periods=first.n_periods, excited=stack([p.excited[lines] for p in parts]),
        rebuild=rebuild if terms else None,
        realisation=np.repeat(np.arange(len(parts)), n_lines) if several else None,
    )


class _Realisation:
    """The period-averaged spectra of one realisation, its noise and its basis spectra (:func:`line_data`)."""

    def __init__(self, signals: Signals, terms, velocity_method: str, drop: int) -> None:
        period = int(signals.period or 0)
        x_periods = period_dft(signals.displacement, period, drop)
        f_periods = period_dft(signals.force, period, drop)
        n_periods = x_periods.shape[0]
        if n_periods < 2:
            raise InputDataError(
                f"the frequency route needs at least two periods for the noise level, the record holds {n_periods}"
            )
        self.signals, self.terms, self.velocity_method, self.period = signals, terms, velocity_method, period
        self.n_periods = n_periods
        self.x_mean, self.f_mean = x_periods.mean(axis=0), f_periods.mean(axis=0)
        self.omega = 2 * np.pi * np.fft.rfftfreq(period, 1.0 / signals.fs)
        self.v_mean = None if signals.velocity is None else period_dft(signals.velocity, period, drop).mean(axis=0)
        dev = x_periods - self.x_mean
        self.cov = np.einsum("pki,pkj->kij", dev, dev.conj()) / (n_periods - 1) / n_periods
        power = np.sum(np.abs(self.f_mean) ** 2, axis=1)
        noise = np.sum(np.abs(f_periods - self.f_mean) ** 2, axis=(0, 2)) / (n_periods - 1) / n_periods
        self.excited = excited_lines(power, noise)

    def basis_spectra(self, x_spec, v_spec):
        """``[F; -N]`` on every line, N from the displacement (and velocity) spectra of one period.

        The memoryless basis functions are evaluated on a finer grid, so that their harmonics
        above the Nyquist frequency do not fold onto the band (:mod:`._aft`).
        """
        period, signals = self.period, self.signals
        if v_spec is None:
            v_spec = 1j * self.omega[:, None] * x_spec
            if period % 2 == 0:
                v_spec[-1] = 0.0  # the Nyquist line of a real signal has no derivative
        n_basis = basis_spectra(self.terms, x_spec, v_spec, self.f_mean, signals.fs, signals.input_dofs,
                                signals.output_dofs, period)
        return np.concatenate([self.f_mean, n_basis], axis=1)

    def rebuild(self, lines, model_outputs):
        """The basis spectra on ``lines`` with the displacement there replaced by ``model_outputs``."""
        x_spec = self.x_mean.copy()
        x_spec[lines] = model_outputs
        v_spec = None
        if self.v_mean is not None:
            v_spec = self.v_mean.copy()
            v_spec[lines] = 1j * self.omega[lines, None] * model_outputs
        return self.basis_spectra(x_spec, v_spec)[lines]


def subspace(data: LineData, block_rows: int, points=None):
    """Whitened range of the stacked outputs projected off the stacked inputs.

    ``points`` replace ``data.z`` as the unit-circle variable (e.g. the bilinear map of jω).

    Returns
    -------
    left : ndarray, shape (r l, r l)
        Left singular vectors un-whitened (columns span the estimate of O_r).
    singular_values : ndarray, shape (r l,)
    scales : (ndarray, ndarray)
        Channel scales of inputs and outputs used for conditioning.
    """
    U, Y = data.inputs, data.outputs
    z = data.z if points is None else np.asarray(points)
    n_lines, n_in = U.shape
    n_out = Y.shape[1]
    r = int(block_rows)
    if r < 1 or r * (n_in + n_out) > 2 * n_lines:
        raise BlockRowsError(
            f"{r} block rows need at least {r * (n_in + n_out) // 2} lines, the band holds {n_lines} excited "
            f"lines; lower [nsi] block_rows to at most {max(1, 2 * n_lines // (n_in + n_out))} or widen the band"
        )
    u_scale, y_scale = _rms(U), _rms(Y)
    Us, Ys = U / u_scale, Y / y_scale
    powers = z[None, :] ** np.arange(r)[:, None]  # (r, M)
    stacked_u = (powers[:, None, :] * Us.T[None]).reshape(r * n_in, n_lines)
    stacked_y = (powers[:, None, :] * Ys.T[None]).reshape(r * n_out, n_lines)
    real = lambda a: np.hstack([a.real, a.imag])  # noqa: E731
    R = scipy.linalg.qr(np.vstack([real(stacked_u), real(stacked_y)]).T, mode="r", check_finite=False)[0]
    ru = r * n_in
    projected = R[ru:, ru:].T  # rows of 𝒴 Π⊥ in an orthonormal basis of the columns
    cov = data.output_cov / np.outer(y_scale, y_scale)[None]
    # z_k^a conj(z_k^b) = z_k^(a-b) on the unit circle: the weight is block Toeplitz in the lags a - b
    lags = np.arange(-(r - 1), r)
    by_lag = np.real(np.tensordot(z[None, :] ** lags[:, None], cov, axes=([1], [0])))  # (2r-1, l, l)
    lag = np.arange(r)[:, None] - np.arange(r)[None, :] + r - 1
    weight = by_lag[lag].transpose(0, 2, 1, 3).reshape(r * n_out, r * n_out)
    weight = (weight + weight.T) / 2 + 1e-12 * np.trace(weight) / len(weight) * np.eye(len(weight))
    chol = np.linalg.cholesky(weight)
    whitened = scipy.linalg.solve_triangular(chol, projected, lower=True, check_finite=False)
    left, singular_values, _ = scipy.linalg.svd(whitened, overwrite_a=True, check_finite=False)
    return chol @ left, singular_values, (u_scale, y_scale)


def system_ac(left: np.ndarray, order: int, n_out: int, y_scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A and C (physical output units) by shift invariance of the estimated O_r."""
    obs = left[:, :order]
    A = np.linalg.lstsq(obs[:-n_out], obs[n_out:], rcond=None)[0]
    return A, obs[:n_out] * y_scale[:, None]


def input_matrices(data: LineData, A: np.ndarray, C: np.ndarray, zero_feedthrough: bool, points=None):
    """B and D by least squares on the lines, weighted by the (smoothed) output noise level.

    ``points`` are where the transfer function is evaluated: ``z_k`` (default, discrete A) or
    ``jω_k`` (continuous A).

    Returns
    -------
    B, D : ndarray
    weighted_residual : ndarray, shape (M, l) complex
        Whitened residual of the fit on the lines.
    """
    fit = _weighted_fit(data, A, C, zero_feedthrough, points)
    return fit["B"], fit["D"], fit["residual"]


def _weighted_fit(data: LineData, A, C, zero_feedthrough: bool, points=None) -> dict:
    """The weighted linear least squares of :func:`input_matrices` for any A (the refinement's modal
    A_c uses :class:`._modal_fit.ModalProblem`, the same least squares arranged for that form)."""
    U, Y = data.inputs, data.outputs
    z = data.z if points is None else np.asarray(points)
    n_lines, n_in = U.shape
    n_out, n = C.shape
    u_scale = _rms(U)
    Us = U / u_scale
    sigma = data.output_std
    lam, vec = np.linalg.eig(A)
    G = ((C @ vec)[None] / (z[:, None] - lam[None])[:, None, :]) @ np.linalg.inv(vec)  # C (zI-A)^-1, (M, l, n)
    phi_b = np.einsum("kj,koi->koji", Us, G).reshape(n_lines, n_out, n_in * n)
    blocks = [phi_b]
    if not zero_feedthrough:
        eye = np.eye(n_out)
        blocks.append(np.einsum("kj,op->kojp", Us, eye).reshape(n_lines, n_out, n_in * n_out))
    phi = np.concatenate(blocks, axis=2) / sigma[:, :, None]
    target = Y / sigma
    design = np.vstack([phi.real.reshape(-1, phi.shape[2]), phi.imag.reshape(-1, phi.shape[2])])
    rhs = np.concatenate([target.real.ravel(), target.imag.ravel()])
    col = np.linalg.norm(design, axis=0)
    col[col == 0] = 1.0
    q, r = np.linalg.qr(design / col)
    theta = np.linalg.lstsq(r, q.T @ rhs, rcond=None)[0] / col
    B = np.real(theta[: n_in * n].reshape((n, n_in), order="F")) / u_scale
    D = np.zeros((n_out, n_in))
    if not zero_feedthrough:
        D = theta[n_in * n :].reshape((n_out, n_in), order="F") / u_scale
    fitted = np.einsum("kom,mj,kj->ko", G, B, U) + U @ D.T
    return dict(B=B, D=D, residual=(Y - fitted) / sigma)


def _rms(a: np.ndarray) -> np.ndarray:
    scale = np.sqrt(np.mean(np.abs(a) ** 2, axis=0))
    return np.where(scale > 0, scale, 1.0)


def _smoothed(var: np.ndarray) -> np.ndarray:
    """Running median over neighbouring lines (a variance from few periods scatters by χ²)."""
    import scipy.ndimage  # here: 0.07 s to import, and the time route never needs it

    out = scipy.ndimage.median_filter(var, size=(_SMOOTH_LINES, 1), mode="nearest")
    positive = out[out > 0]
    floor = 1e-12 * (np.max(positive) if positive.size else 1.0)
    return np.maximum(out, floor)


def bilinear_points(freqs_hz: np.ndarray) -> tuple[np.ndarray, float]:
    """``(ω0 + jω)/(ω0 - jω)`` on the lines, ω0 the geometric centre of the band: jω on the unit circle."""
    omega = 2 * np.pi * np.asarray(freqs_hz)
    omega0 = float(np.sqrt(omega[0] * omega[-1]))
    return (omega0 + 1j * omega) / (omega0 - 1j * omega), omega0


def continuous_ac(A_tilde: np.ndarray, C_tilde: np.ndarray, omega0: float):
    """Continuous A_c, C_c from the bilinear-domain pair (s = ω0 (z - 1)/(z + 1)); C_c up to the B scaling."""
    inv = np.linalg.inv(A_tilde + np.eye(len(A_tilde)))
    return omega0 * inv @ (A_tilde - np.eye(len(A_tilde))), C_tilde @ inv


def stabilise_continuous(Ac: np.ndarray):
    """Reflect poles with Re s >= 0 into the left half-plane (-conj s); the reflected ones."""
    lam, vec = np.linalg.eig(Ac)
    outside = lam.real >= 0
    if not outside.any():
        return Ac, lam[:0]
    reflected = lam.copy()
    reflected[outside] = -np.conj(lam[outside])
    return np.real(vec @ np.diag(reflected) @ np.linalg.inv(vec)), lam[outside]


def refine(data: LineData, Ac: np.ndarray, C: np.ndarray, zero_feedthrough: bool, max_nfev: int = 200):
    """Weighted least-squares refinement of A_c, C on the lines (:func:`._modal_fit.refine`).

    Returns the better of start and end, as ``(A_c, C, (B_c, D_c, whitened residual))``
    (:func:`input_matrices` of the start when the refinement does not gain).
    """
    from ._modal_fit import refine as modal_refine

    jw = 2j * np.pi * data.freqs_hz
    found = modal_refine(data.inputs, data.outputs, data.output_std, jw, Ac, C, zero_feedthrough, max_nfev)
    if found is None:
        return Ac, C, input_matrices(data, Ac, C, zero_feedthrough, jw)
    A, C_new, B, D, residual, _ = found
    return A, C_new, (B, D, residual)
