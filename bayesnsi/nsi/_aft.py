"""Basis spectra of one period by alternating frequency-time evaluation without aliasing (docs/method.md §11).

The frequency route fits the extended input ``[F; -N]`` on the lines of one period: ``N`` is the
DFT of the basis functions evaluated on the period-averaged response. A basis function that
switches sharply (``tanh(v/ε)`` with ε well below the velocity spread, ``sign(v)``, a clearance) has
harmonics far above the data's Nyquist frequency; evaluated at the data's samples, each folds back
onto a line inside the band, a force the structure never felt there. The error grows as the
switch sharpens, so the evidence and the coefficients of a sharp friction are biased towards wide
widths. As in the alternating frequency-time method of harmonic balance (Cameron and Griffin 1989),
the response (band-limited to the period's lines) is interpolated on a grid :data:`OVERSAMPLING`
times finer by zero-padding its spectrum, the basis evaluated there, and the DFT of the result
kept on the period's lines. Terms with memory (Bouc-Wen, docs/method.md §12) are integrated at the
data's samples, as in identification on the time route.
"""

from __future__ import annotations

import numpy as np

from ..signals import Signals
from .feedback import extended_input

__all__ = ["OVERSAMPLING", "basis_spectra", "fine_period"]

OVERSAMPLING = 8
"""Samples per data sample of the grid memoryless basis functions are evaluated on. On the simulated
ground vibration test at 1 N (seed 0, 64 Hz, the relative velocity of DOFs 7-8), the band lines of
``tanh(v/0.002)`` (the joint's friction) are 21 % off at the data's samples, 2.2 % at 4x, 0.35 % at
8x (against 16x); those of ``tanh(v/0.0091)`` 8.8 %, 0.06 %, below 0.01 %."""


def fine_period(spectrum: np.ndarray, period: int, factor: int) -> np.ndarray:
    """One period of the real signal with ``spectrum`` (rfft / period) on ``factor · period`` samples.

    Parameters
    ----------
    spectrum : ndarray, shape (period // 2 + 1, ...)
        The lines of one period, scaled as ``rfft(x) / period``.
    period : int
        Samples per period at the data's rate.
    factor : int
        Oversampling factor (1: the data's samples).

    Returns
    -------
    ndarray, shape (factor · period, ...)
        The band-limited interpolation (zero-padded spectrum); the Nyquist line of an even period is
        a cosine at the data's rate, split between its two aliases on the finer grid.
    """
    n = period * factor
    full = np.zeros((n // 2 + 1,) + spectrum.shape[1:], dtype=complex)
    full[: spectrum.shape[0]] = spectrum
    if factor > 1 and period % 2 == 0:
        full[period // 2] *= 0.5
    return np.fft.irfft(full * n, n, axis=0)


def basis_spectra(terms, x_spec: np.ndarray, v_spec: np.ndarray, force_spec: np.ndarray, fs: float, input_dofs,
                  output_dofs, period: int, strict: bool = True, oversampling: int = OVERSAMPLING) -> np.ndarray:
    """DFT of ``-n_i`` over one period on its lines, memoryless terms evaluated on the finer grid.

    Parameters
    ----------
    terms : sequence of Term
    x_spec, v_spec : ndarray, shape (period // 2 + 1, l)
        Displacement and velocity of the output DOFs on the period's lines (rfft / period).
    force_spec : ndarray, shape (period // 2 + 1, m)
        The forces on the same lines (only checked, with ``strict``).
    fs : float
        The data's sampling frequency [Hz].
    input_dofs, output_dofs : sequence of int
    period : int
        Samples per period at ``fs``.
    strict : bool
        As in identification (:func:`bayesnsi.nsi.feedback.extended_input`: a term constant on the
        response is not identifiable, an error). False for a model's own response (harmonic
        balance): a term that is zero there (a clearance whose gap the motion never reaches) is a
        zero force.
    oversampling : int
        Samples per data sample of the grid the memoryless terms are evaluated on.

    Returns
    -------
    ndarray, shape (period // 2 + 1, q)
        ``rfft(-n_i) / samples`` on the period's lines, one column per term, in order.
    """
    out = np.zeros((period // 2 + 1, len(terms)), dtype=complex)
    memory = [i for i, t in enumerate(terms) if t.expr.memory is not None]
    plain = [i for i in range(len(terms)) if i not in memory]
    for index, factor in ((plain, int(oversampling)), (memory, 1)):
        if not index:
            continue
        n = period * factor
        x, v = fine_period(x_spec, period, factor), fine_period(v_spec, period, factor)
        chosen = [terms[i] for i in index]
        if strict:
            one = Signals(force=fine_period(force_spec, period, factor), displacement=x, velocity=v, fs=fs * factor,
                          input_dofs=tuple(input_dofs), output_dofs=tuple(output_dofs), period=n)
            columns = extended_input(one, chosen, "fourth", "sample")[:, len(input_dofs):]
        else:
            columns = _point_values(chosen, output_dofs, x, v)
        out[:, index] = np.fft.rfft(columns, axis=0)[: period // 2 + 1] / n
    return out


def _point_values(terms, output_dofs, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``-n_i(x, v)`` on a model's own response over one period (n, q): a term that is zero there is a zero force.

    A term with memory is its periodic steady state over the period (docs/method.md §12).
    """
    rows = {int(d) - 1: k for k, d in enumerate(output_dofs)}
    xs = {row: x[:, k] for row, k in rows.items()}
    vs = {row: v[:, k] for row, k in rows.items()}
    columns = [-np.broadcast_to(np.asarray(term.evaluate(xs, vs, periodic=True) if term.expr.memory is not None
                                           else term.expr.function(xs, vs), dtype=float), (len(x),))
               for term in terms]
    return np.column_stack(columns) if columns else np.zeros((len(x), 0))
