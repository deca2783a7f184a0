"""NSI core: Hankel routes, exact recovery on systems whose truth is known in closed form.

Reference values are independent computations: explicit Hankel products (numpy), the exact
zero-order-hold discretisation (scipy.linalg.expm) of chains whose poles are eig(A_c).
"""

import numpy as np
import pytest

from bayesnsi.exceptions import BlockRowsError, NotIdentifiableError, OrderError
from bayesnsi.models import CandidateModel, Term
from bayesnsi.nsi import StateSpaceModel, _hankel, identify, select_order
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from tests._helpers.cases import zoh_chain

TIGHT = 1e-6  # relative agreement of noise-free exact recoveries


def random_stable_system(rng, n_modes=3, n_in=2, n_out=3, dt=0.01):
    """Random discrete system with lightly damped modes between 1 and 20 Hz."""
    freqs = rng.uniform(1.0, 20.0, n_modes) * 2 * np.pi
    zetas = rng.uniform(0.005, 0.05, n_modes)
    poles = -zetas * freqs + 1j * freqs * np.sqrt(1 - zetas**2)
    blocks = [np.array([[p.real, p.imag], [-p.imag, p.real]]) for p in poles]
    Ac = np.zeros((2 * n_modes, 2 * n_modes))
    for k, b in enumerate(blocks):
        Ac[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = b
    T = rng.standard_normal((2 * n_modes, 2 * n_modes))
    Ac = T @ Ac @ np.linalg.inv(T)
    from scipy.linalg import expm

    A = expm(Ac * dt)
    B = rng.standard_normal((2 * n_modes, n_in))
    C = rng.standard_normal((n_out, 2 * n_modes))
    return StateSpaceModel(A, B, C, np.zeros((n_out, n_in)), dt), np.concatenate([poles, poles.conj()])


def match_poles(found, expected):
    found, expected = np.sort_complex(found), np.sort_complex(expected)
    return np.max(np.abs(found - expected) / np.abs(expected))


@pytest.mark.parametrize("block_rows", [2, 5, 9])
def test_hankel_gram_equals_explicit_product(rng, block_rows):
    z = rng.standard_normal((301, 3))
    two_i = 2 * block_rows
    j = len(z) - two_i + 1
    H = np.vstack([z[r : r + j].T for r in range(two_i)])  # interleaved block rows
    np.testing.assert_allclose(_hankel.hankel_gram(z, block_rows), H @ H.T, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("old", [[0, 1, 3], [1, 2], [0, 3]])
def test_extended_lagged_products_equal_the_full_pass(rng, old):
    # reference: the one-pass products of all channels (lagged_products), checked above against H Hᵀ
    z = rng.standard_normal((9000, 4))  # > 2 chunks of 4096 samples
    old = np.array(old)
    partial = _hankel.lagged_products(z[:, old], 10)
    np.testing.assert_allclose(
        _hankel.extend_lagged_products(partial, z, old), _hankel.lagged_products(z, 10), rtol=1e-12, atol=1e-9
    )


def test_identify_with_shared_correlations_equals_the_full_computation():
    # a candidate plus one term, from the products of the candidate (closing the loop's fast path)
    from bayesnsi.nsi import hankel_correlations
    from bayesnsi.simulate import simulate_case

    case = simulate_case("two-dof", seed=0)
    base = CandidateModel.from_terms("base", [("v1*abs(v1)", 1)])
    larger = base.with_term(Term("x1**3", 1))
    shared = hankel_correlations(case.signals, base, NSIOptions(block_rows=30))
    fast = identify(case.signals, larger, NSIOptions(block_rows=30, order=4), correlations=shared)
    full = identify(case.signals, larger, NSIOptions(block_rows=30, order=4))
    np.testing.assert_allclose(fast.singular_values, full.singular_values, rtol=1e-9)
    np.testing.assert_allclose(fast.coefficient_values, full.coefficient_values, rtol=1e-7)
    # products of another candidate, or other settings, are ignored rather than misused
    sign_candidate = CandidateModel.from_terms("c", [("sign(v1)", 1)])
    other = hankel_correlations(case.signals, sign_candidate, NSIOptions(block_rows=30))
    unrelated = identify(case.signals, larger, NSIOptions(block_rows=30, order=4), correlations=other)
    np.testing.assert_allclose(unrelated.coefficient_values, full.coefficient_values, rtol=1e-12)
    mismatched = identify(case.signals, larger, NSIOptions(block_rows=20, order=4), correlations=shared)
    fresh = identify(case.signals, larger, NSIOptions(block_rows=20, order=4))
    np.testing.assert_allclose(mismatched.coefficient_values, fresh.coefficient_values, rtol=1e-12)


def test_gram_and_lq_factors_agree(rng):
    z = rng.standard_normal((2000, 4))
    L1 = _hankel.gram_factor(z, 6, 1)
    L2 = _hankel.lq_factor(z, 6, 1)
    np.testing.assert_allclose(L1 @ L1.T, L2 @ L2.T, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_random_systems_both_routes_recover_poles_and_frf(seed):
    rng = np.random.default_rng(seed)
    model, poles = random_stable_system(rng)
    u = rng.standard_normal((4000, 2))
    y = model.simulate(u)
    sig = Signals(u, y, 1 / model.dt, [1, 2], [1, 2, 3])
    freqs = np.linspace(0.5, 25, 50)
    exact_frf = model.frf(freqs)
    results = {
        route: identify(sig, None, NSIOptions(block_rows=8, order=6, route=route, input_hold="sample"))
        for route in ("correlation", "lq")
    }
    for res in results.values():
        assert match_poles(res.model.poles, poles) < TIGHT
        np.testing.assert_allclose(res.frf(freqs), exact_frf, rtol=TIGHT, atol=TIGHT * np.abs(exact_frf).max())
    a, b = results["correlation"], results["lq"]
    assert match_poles(a.model.poles, b.model.poles) < 1e-9
    np.testing.assert_allclose(a.frf(freqs), b.frf(freqs), rtol=1e-8, atol=1e-10 * np.abs(exact_frf).max())


def test_auto_order_finds_true_order(rng):
    model, _ = random_stable_system(rng, n_modes=2)
    u = rng.standard_normal((3000, 2))
    y = model.simulate(u) * (1 + 0 * u[:, :1])
    sig = Signals(u, y + 1e-6 * rng.standard_normal(y.shape), 1 / model.dt, [1, 2], [1, 2, 3])
    assert identify(sig, None, NSIOptions(block_rows=10, input_hold="sample")).order == 4
    assert select_order(np.array([10.0, 9.0, 1.0, 0.9, 1e-3, 1e-3]), 5) == 4


def _discrete_feedback_chain(
    term_expr, at, coefficient, force_dofs, output_dofs, n_samples=6000, seed=0, force_rms=2.0
):
    """Two-DOF chain, exact ZOH model, nonlinear term fed back in discrete time.

    x_{k+1} = A x_k + B_f f_k - λ B_l n(y_k, v_k): the extended-input model of SPEC Eq. 8 holds
    exactly, so NSI must recover λ and the poles to rounding.
    """
    dt = 0.01
    Ac, A, Bd, n = zoh_chain([1.0, 1.5], [800.0, 1000.0], [1.0, 1.0], dt, force_dofs)
    term = Term(term_expr, at)
    loc = term.location_vector(n)
    rng = np.random.default_rng(seed)
    f = force_rms * rng.standard_normal((n_samples, len(force_dofs)))
    b_force = Bd[:, [d - 1 for d in force_dofs]]
    b_term = Bd @ loc
    x = np.zeros(2 * n)
    disp, vel = np.empty((n_samples, n)), np.empty((n_samples, n))
    for k in range(n_samples):
        disp[k], vel[k] = x[:n], x[n:]
        x = A @ x + b_force @ f[k] - coefficient * b_term * term.evaluate(x[:n, None], x[n:, None])[0]
    cols = [d - 1 for d in output_dofs]
    sig = Signals(f, disp[:, cols], 1 / dt, force_dofs, output_dofs, velocity=vel[:, cols])
    return sig, np.linalg.eigvals(Ac), term


@pytest.mark.parametrize(
    "expr, at, coef, forces, outputs",
    [
        ("v1*abs(v1)", 1, 20.0, [2], [1, 2]),  # reciprocity route (paper two-DOF layout)
        ("x1**3", 1, 2e5, [1], [1, 2]),  # direct route: force at the term's DOF
        ("(x1-x2)**3", [1, 2], 2e5, [2], [1, 2]),  # element between DOFs, reciprocity
    ],
)
def test_exact_discrete_feedback_recovers_coefficient(expr, at, coef, forces, outputs):
    sig, poles, term = _discrete_feedback_chain(expr, at, coef, forces, outputs)
    res = identify(sig, CandidateModel("true", (term,)), NSIOptions(block_rows=10, order=4, input_hold="sample"))
    assert match_poles(res.model.poles, poles) < TIGHT
    # λ(ω) is exactly constant: real part = λ, imaginary part = 0
    assert res.coefficients[0].value == pytest.approx(coef, rel=TIGHT)
    assert res.coefficients[0].imag_ratio < TIGHT
    spectrum = res.coefficient_spectrum(np.linspace(1, 9, 20))
    np.testing.assert_allclose(spectrum[:, 0], coef, rtol=TIGHT)
    assert res.reconstruct(sig).nrmse < TIGHT
    assert res.reconstruct(sig, closed_loop=True).nrmse < 1e-5


def test_unidentifiable_coefficient_is_reported():
    # force at DOF 2, response only at DOF 1: a term at DOF 1 has neither route
    sig, _, _ = _discrete_feedback_chain("x1**3", 1, 1e5, [2], [1, 2], n_samples=800)
    one_output = Signals(sig.force, sig.displacement[:, :1], sig.fs, [2], [1], velocity=sig.velocity[:, :1])
    with pytest.raises(NotIdentifiableError, match="cannot be identified"):
        identify(one_output, [("x1**3", 1)], NSIOptions(block_rows=8, order=2))
    with pytest.raises(NotIdentifiableError, match="not measured"):
        identify(one_output, [("x2**3", 2)], NSIOptions(block_rows=8, order=2))


def test_block_rows_and_order_errors(rng):
    sig = Signals(rng.standard_normal((100, 1)), rng.standard_normal((100, 2)), 100.0, [1], [1, 2])
    with pytest.raises(BlockRowsError, match="too few"):
        identify(sig, None, NSIOptions(block_rows=30))
    with pytest.raises(OrderError, match="impossible"):
        identify(sig, None, NSIOptions(block_rows=4, order=50))


# --------------------------------------------------------------------------------------------
# modal simulation against the plain state recursion x_{k+1} = A x_k + B u_k, y_k = C x_k + D u_k


def direct_recursion(model, u, x0):
    x, out = np.array(x0, dtype=float), []
    for k in range(len(u)):
        out.append(model.C @ x + model.D @ u[k])
        x = model.A @ x + model.B @ u[k]
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_modal_simulation_equals_state_recursion(seed):
    rng = np.random.default_rng(seed)
    model, _ = random_stable_system(rng)
    model = StateSpaceModel(model.A, model.B, model.C, rng.standard_normal(model.D.shape), model.dt)
    # one real mode as well: append a first-order state
    A = np.block([[model.A, np.zeros((model.order, 1))], [np.zeros((1, model.order)), np.array([[0.7]])]])
    B = np.vstack([model.B, rng.standard_normal((1, model.B.shape[1]))])
    C = np.hstack([model.C, rng.standard_normal((model.C.shape[0], 1))])
    model = StateSpaceModel(A, B, C, model.D, model.dt)
    u = rng.standard_normal((400, model.B.shape[1]))
    x0 = rng.standard_normal(model.order)
    expected = direct_recursion(model, u, x0)
    scale = np.abs(expected).max()
    assert np.abs(model.simulate(u, x0) - expected).max() < 1e-10 * scale
    each = model.simulate_each(u)
    assert np.abs(each.sum(axis=2) + model.initial_response(x0, len(u)) - expected).max() < 1e-10 * scale
    for c in range(u.shape[1]):
        alone = np.zeros_like(u)
        alone[:, c] = u[:, c]
        assert np.abs(each[:, :, c] - direct_recursion(model, alone, np.zeros(model.order))).max() < 1e-10 * scale


@pytest.mark.parametrize(
    "eigenvalue", [0.999 * np.exp(0.05j), 0.5 + 0.5j, 0.99999 * np.exp(2e-3j), 0.9999995 * np.exp(1e-4j), -0.3]
)
def test_modal_filter_matches_complex_recursion(eigenvalue):
    from scipy import signal

    from bayesnsi.nsi.statespace import modal_filter, modal_filter_step

    u = np.random.default_rng(0).standard_normal(20000)
    expected = signal.lfilter([0.0, 1.0], [1.0, -eigenvalue], u.astype(complex))
    assert np.abs(modal_filter(eigenvalue, u) - expected).max() < 1e-9 * np.abs(expected).max()
    # chunk by chunk with the carried state: the same signal
    state, parts = None, []
    for chunk in np.array_split(u, 7):
        out, state = modal_filter_step(complex(eigenvalue), chunk, state)
        parts.append(out)
    assert np.abs(np.concatenate(parts) - expected).max() < 1e-9 * np.abs(expected).max()


def _relative_imports(module) -> set[str]:
    import ast
    import inspect

    tree = ast.parse(inspect.getsource(module))
    return {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level == 1}


def test_noise_estimate_sits_below_both_refinements():
    # the output-error refinement and the errors-in-variables step share the noise estimate
    # of the measured channels; it lives in the noise package below both, which imports neither back
    import ast
    import inspect

    from bayesnsi.noise import levels
    from bayesnsi.nsi import _eiv, _output_error

    def imports(module) -> set[str]:
        tree = ast.parse(inspect.getsource(module))
        return {f"{'.' * node.level}{node.module}" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}

    assert ".._eiv" not in imports(_output_error) and "._eiv" not in imports(_output_error)
    assert "._output_error" in imports(_eiv) and "..noise" in imports(_eiv) and "..noise" in imports(_output_error)
    assert not any("nsi" in name or "_eiv" in name or "_output_error" in name for name in imports(levels))


def test_stabilization_uses_the_singular_values_of_identify():
    # stabilization() and identify() share the scaled [u, y] and the oblique projection
    from bayesnsi.nsi import stabilization
    from bayesnsi.simulate import simulate_case

    case = simulate_case("two-dof", seed=0)
    result = identify(case.signals, case.true_terms, NSIOptions(block_rows=20, order=4))
    singular_values, diagram = stabilization(case.signals, case.true_terms, block_rows=20, orders=[4])
    np.testing.assert_array_equal(singular_values, result.singular_values)
    assert diagram[0][0] == 4 and diagram[0][1].shape == (len(result.modes), 2)
