"""The FNSI refinement's vectorised inner loop (for speed) gives the numbers of the
general weighted least squares, and its Jacobian is that of the projected residual."""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.nsi import _fnsi
from bayesnsi.nsi._modal_fit import ModalProblem


def _problem(zero_feedthrough: bool, seed: int = 0, exact: bool = False):
    rng = np.random.default_rng(seed)
    n_lines, n_in, n_out = 60, 3, 2
    freqs = np.linspace(1.0, 12.0, n_lines)
    U = rng.standard_normal((n_lines, n_in)) + 1j * rng.standard_normal((n_lines, n_in))
    Y = rng.standard_normal((n_lines, n_out)) + 1j * rng.standard_normal((n_lines, n_out))
    cov = np.abs(rng.standard_normal((n_lines, n_out))) + 0.1
    data = _fnsi.LineData(lines=np.arange(n_lines), freqs_hz=freqs, z=np.exp(2j * np.pi * freqs / 100),
                          inputs=U, outputs=Y, output_cov=np.stack([np.diag(c) for c in cov]), n_periods=4)
    damping, omega = np.array([-0.8, -2.0, -1.1]), np.array([2 * np.pi * 3, 2 * np.pi * 7, 2 * np.pi * 10])
    C = rng.standard_normal((n_out, 6))
    A = np.zeros((6, 6))
    for i, (s, w) in enumerate(zip(damping, omega)):
        A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = [[s, w], [-w, s]]
    jw = 2j * np.pi * freqs
    if exact:  # outputs of a model with these poles and C: zero residual, where Kaufman's Jacobian is exact
        G = C @ np.linalg.inv(jw[:, None, None] * np.eye(6)[None] - A[None])
        Y = np.einsum("kon,nj,kj->ko", G, rng.standard_normal((6, n_in)), U) + U @ rng.standard_normal((n_out, n_in)).T
        data = _fnsi.LineData(lines=data.lines, freqs_hz=freqs, z=data.z, inputs=U, outputs=Y,
                              output_cov=data.output_cov, n_periods=4)
    return data, A, C, damping, omega, jw, ModalProblem(U, Y, data.output_std, jw, zero_feedthrough)


@pytest.mark.parametrize("zero_feedthrough", [False, True])
def test_modal_fit_equals_the_general_weighted_least_squares(zero_feedthrough):
    data, A, C, damping, omega, jw, problem = _problem(zero_feedthrough)
    B, D, residual = _fnsi.input_matrices(data, A, C, zero_feedthrough, jw)  # eig-based resolvent
    fit = problem.fit(damping, omega, C)
    np.testing.assert_allclose(fit["B"], B, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fit["D"], D, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fit["residual"], residual, rtol=1e-9, atol=1e-12)
    resolvent = np.linalg.inv(jw[:, None, None] * np.eye(6)[None] - A[None])  # independent: dense inverse
    np.testing.assert_allclose(fit["G"], C @ resolvent, rtol=1e-10, atol=1e-14)


def test_modal_jacobian_matches_finite_differences():
    _, _, C, damping, omega, _, problem = _problem(False, seed=1, exact=True)
    n_pairs, n_out = len(damping), C.shape[0]

    def residual(theta):
        res = problem.fit(-np.exp(theta[:n_pairs]), theta[n_pairs : 2 * n_pairs],
                          theta[2 * n_pairs :].reshape(n_out, -1))["residual"]
        return np.concatenate([res.real.ravel(), res.imag.ravel()])

    theta = np.concatenate([np.log(-damping), omega, C.ravel()])
    J = problem.jacobian(problem.fit(damping, omega, C), damping)
    step = 1e-6
    numeric = np.column_stack([(residual(theta + step * e) - residual(theta - step * e)) / (2 * step)
                               for e in np.eye(len(theta))])
    # Kaufman's Jacobian drops a term proportional to the residual: exact at a zero-residual fit
    np.testing.assert_allclose(J, numeric, atol=1e-6 * np.abs(numeric).max())
