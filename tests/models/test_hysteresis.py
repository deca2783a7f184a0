"""The Bouc-Wen hysteretic term: grammar, integration rule, periodic steady state, reading, reference simulator.

Reference values come from an independent fine-step RK4 of the Bouc-Wen law written here, in time,
along the same displacement path (docs/method.md §12).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from bayesnsi.exceptions import ExpressionError, InputDataError
from bayesnsi.io.units import ChannelUnits, term_unit
from bayesnsi.models import (
    BoucWen,
    Term,
    boucwen_path,
    boucwen_periodic,
    default_shapes,
    hysteresis_effect,
    hysteresis_reading,
    parse_expression,
)
from bayesnsi.models.hysteresis import _path_by_sample, boucwen_step
from bayesnsi.nsi import extended_input
from bayesnsi.signals import Signals
from bayesnsi.simulate import simulate_hysteretic_response, simulate_response
from bayesnsi.simulate.multisine import multisine

SHAPES = [BoucWen(150.0, -50.0), BoucWen(800.0, -1100.0), BoucWen(10.0, 30.0), BoucWen(100.0, 150.0)]


def fine_rk4(shape: BoucWen, x: np.ndarray, substeps: int = 2000, z0: float = 0.0) -> np.ndarray:
    """z at the samples of ``x`` by RK4 in time of ż = ẋ - β|ẋ||z|^(n-1)z - γẋ|z|^n, ẋ constant per interval."""

    def rate(z, v):
        power = abs(z) ** shape.n
        return v - shape.beta * abs(v) * np.sign(z) * power - shape.gamma * v * power

    out, z, h = [z0], z0, 1.0 / substeps
    for dx in np.diff(x):
        for _ in range(substeps):  # unit time per interval: the rate is the increment
            k1 = rate(z, dx)
            k2 = rate(z + h / 2 * k1, dx)
            k3 = rate(z + h / 2 * k2, dx)
            k4 = rate(z + h * k3, dx)
            z += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(z)
    return np.array(out)


def test_a_boucwen_term_parses_writes_back_and_pickles():
    expr = parse_expression("boucwen( x1 , beta = 800, gamma = -1.1e3 )")
    assert expr.canonical == "boucwen(x1,beta=800,gamma=-1100)"
    assert expr.memory == BoucWen(800.0, -1100.0) and expr.displacement_dofs == (1,) and not expr.velocity_dofs
    assert parse_expression(expr.canonical).canonical == expr.canonical
    assert pickle.loads(pickle.dumps(expr)).canonical == expr.canonical
    pair = Term("boucwen((x3-x4), beta=2, gamma=1, n=2)", [3, 4])
    assert pair.name == "boucwen(x3-x4,beta=2,gamma=1,n=2)@3-4" and pair.expr.memory.n == 2.0
    assert term_unit(pair.expr.canonical, ChannelUnits("N", "m", "m/s")) == "N/m"  # λ is a stiffness
    assert not expr.switches_with_velocity and not expr.uses_velocity


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("boucwen(v1, beta=1, gamma=2)", "follows a displacement"),
        ("boucwen(x1*x2, beta=1, gamma=2)", "follows a displacement"),
        ("boucwen(x1-x1, beta=1, gamma=2)", "follows a displacement"),
        ("2*boucwen(x1, beta=1, gamma=2)", "a term of its own"),
        ("boucwen(x1, beta=1, gamma=2) + x1", "a term of its own"),
        ("boucwen(x1, beta=1)", "needs gamma"),
        ("boucwen(x1, beta=1, beta=2, gamma=1)", "gives beta twice"),
        ("boucwen(x1, beta=x1, gamma=1)", "needs a number"),
        ("boucwen(x1, beta=1, gamma=1, n=0)", "n must lie in"),
        ("beta", "expected a number"),
        ("boucwen(x1, beta=1, delta=1)", "unknown name"),
    ],
)
def test_the_grammar_refuses_a_malformed_boucwen_term(text, message):
    with pytest.raises(ExpressionError, match=message):
        parse_expression(text)


@pytest.mark.parametrize("shape", SHAPES, ids=str)
def test_the_exact_rule_is_the_law_along_the_sampled_path(shape):
    # piecewise-linear displacement with reversals and long excursions: exact per branch (module notes)
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.normal(0.0, 2e-3, 40))
    reference = fine_rk4(shape, x)  # its own error at 2000 substeps: about 1e-7 of max |z|
    assert np.max(np.abs(boucwen_path(shape, x) - reference)) <= 1e-6 * np.max(np.abs(reference))


def test_the_general_exponent_is_integrated_to_the_fine_reference():
    shape = BoucWen(300.0, 100.0, 2.5)  # z in m: β, γ in 1/m^n
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.normal(0.0, 0.02, 40))
    reference = fine_rk4(shape, x, substeps=1000)
    assert np.max(np.abs(boucwen_path(shape, x) - reference)) <= 1e-6 * np.max(np.abs(reference))


def test_the_sampling_error_is_second_order_at_reversals():
    # a random-phase sum of sines (1-3 Hz) sampled at fs: the straight path between samples misses
    # the top of a reversal that falls between them; the reference follows the same signal at 6400 Hz
    shape = BoucWen(150.0, -50.0)
    rng = np.random.default_rng(5)
    freqs, phases = rng.uniform(1.0, 3.0, 8), rng.uniform(0.0, 2 * np.pi, 8)

    def signal(fs):
        t = np.arange(20 * fs + 1) / fs
        return 0.006 * np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None]).sum(axis=0)

    reference = boucwen_path(shape, signal(6400))
    errors = []
    for fs in (40, 80, 160):  # ωΔt = 0.47, 0.24, 0.12 at 3 Hz
        fine = reference[:: 6400 // fs]
        errors.append(np.std(boucwen_path(shape, signal(fs)) - fine) / np.std(fine))
    assert errors[1] < 0.01  # 0.5 % at ωΔt = 0.24
    assert all(3.0 < a / b < 6.0 for a, b in zip(errors, errors[1:]))  # halving the step quarters it


def test_the_vector_step_is_the_scalar_path():
    rng = np.random.default_rng(3)
    for shape in [*SHAPES, BoucWen(50.0, 20.0, 2.0)]:
        x = np.cumsum(rng.normal(0.0, 3e-3, 400))
        x[50:60] = x[50]  # at rest: no change
        z = np.zeros(2)
        steps = [z[0]]
        for k in range(1, len(x)):
            z = boucwen_step(shape, z, np.array([x[k] - x[k - 1], 0.0]))
            steps.append(z[0])
        assert np.allclose(steps, boucwen_path(shape, x), rtol=1e-10, atol=1e-15)
        assert np.all(z[1] == 0.0)


@pytest.mark.parametrize("shape", [*SHAPES, BoucWen(5.0, -5.0), BoucWen(0.0, 0.0), BoucWen(40.0, -40.0)], ids=str)
def test_the_path_run_by_run_is_the_path_sample_by_sample(shape):
    # n = 1: between reversals z is the exact flow over the travel since the run began (module notes); the
    # reference composes the same exact step increment by increment, so only rounding may differ
    rng = np.random.default_rng(7)
    smooth = np.convolve(np.cumsum(rng.normal(0.0, 1e-3, 4000)), np.ones(9) / 9, mode="same")
    rough = np.cumsum(rng.normal(0.0, 2e-3, 1000))
    for x, z0 in ((smooth, 0.0), (rough, 0.0), (rough, 3e-3), (0.02 * np.sin(np.arange(2000) / 40.0), -1e-3)):
        x = x.copy()
        x[:5] = x[0]  # at rest before the first move
        x[300:340] = x[300]  # and within the record
        reference = _path_by_sample(shape, x, z0)
        assert np.all(np.isfinite(reference))
        scale = np.max(np.abs(reference))
        assert np.max(np.abs(boucwen_path(shape, x, z0) - reference)) <= 1e-12 * scale


def test_a_path_at_rest_or_empty_keeps_its_start():
    shape = BoucWen(150.0, -50.0)
    assert boucwen_path(shape, np.full(7, 0.3), 2e-3).tolist() == [2e-3] * 7
    assert boucwen_path(shape, np.array([])).shape == (0,)
    assert np.allclose(boucwen_periodic(shape, np.zeros(16)), 0.0)


def test_the_periodic_steady_state_repeats_and_is_where_a_long_record_settles():
    shape = BoucWen(150.0, -50.0)
    t = np.arange(256) / 256
    period = 0.01 * np.sin(2 * np.pi * t) + 0.004 * np.sin(6 * np.pi * t + 1.0)
    steady = boucwen_periodic(shape, period)
    closing = boucwen_step(shape, steady[-1], period[0] - period[-1])
    assert closing == pytest.approx(steady[0], rel=1e-9)
    settled = boucwen_path(shape, np.tile(period, 40))[-256:]
    assert np.allclose(steady, settled, rtol=1e-8, atol=1e-12)
    runaway = BoucWen(-50.0, -50.0)  # β < 0 feeds the loop: no steady state
    with pytest.raises(Exception, match="no periodic steady state"):
        boucwen_periodic(runaway, 0.05 * np.sin(2 * np.pi * t))


def test_the_reading_gives_stiffness_yield_and_the_energy_per_cycle():
    shape, lam = BoucWen(150.0, -50.0), 400.0
    rng = np.random.default_rng(4)
    record = 0.01 * rng.standard_normal(5000)
    reading = hysteresis_reading(shape, lam, record)
    assert reading.yield_displacement == pytest.approx(0.01) and reading.yield_force == pytest.approx(4.0)
    assert reading.amplitude == pytest.approx(np.sqrt(2) * record.std())
    # independent: fine RK4 over many cycles of the sine, the last cycle's ∮ λ z dx by the trapezoid rule
    points = 400
    sine = reading.amplitude * np.sin(2 * np.pi * np.arange(8 * points + 1) / points)
    z = fine_rk4(shape, sine, substeps=20)
    last_x, last_z = sine[-points - 1 :], z[-points - 1 :]
    area = lam * np.sum(0.5 * (last_z[1:] + last_z[:-1]) * np.diff(last_x))
    assert reading.loop_area == pytest.approx(area, rel=2e-3) and reading.loop_area > 0
    assert reading.peak_force == pytest.approx(lam * np.max(np.abs(last_z)), rel=2e-3)
    elastic = hysteresis_reading(BoucWen(0.0, 100.0), lam, record)  # β = 0: no dissipation
    assert abs(elastic.loop_area) < 1e-6 * reading.loop_area
    assert hysteresis_reading(BoucWen(800.0, -1100.0), lam, record).yield_displacement is None  # it hardens


def test_the_grid_spans_the_branches_and_writes_its_parameters_in_the_term():
    shapes = default_shapes(0.01)
    assert len(shapes) == 9 and all(s.beta > 0 for s in shapes)
    branches = np.array([(s.loading * 0.01, s.unloading * 0.01) for s in shapes])
    expected = np.array([(c, u) for c in (-0.25, 0.5, 2.0) for u in (1.0, 3.0, 9.0)])
    assert np.allclose(branches, expected, atol=0.015)  # β, γ kept to 3 significant digits
    effect = hysteresis_effect((1, 2), BoucWen(123.456, -45.678))
    assert effect.term.name == "boucwen(x1-x2,beta=123,gamma=-45.7)@1-2"
    assert effect.name == "boucwen beta=123 gamma=-45.7" and effect.shape == BoucWen(123.0, -45.7)


def _sdof(terms, coefficients, oversample=20, n_periods=3, period=512, seed=0):
    """The benchmark's one-DOF system (2 kg, 10 N s/m, 5e4 N/m) under a 5-150 Hz multisine at 750 Hz."""
    force = multisine(period, 750.0, (5.0, 150.0), rms=50.0, rng=seed, n_periods=n_periods, oversample=oversample)
    function = simulate_hysteretic_response if any(t.expr.memory for t in terms) else simulate_response
    response = function([[2.0]], [[10.0]], [[5e4]], [1], force.fine, 750.0 * oversample, oversample, terms,
                        coefficients)
    return force, response


def test_the_reference_simulator_is_the_linear_simulator_without_memory():
    _, fast = _sdof([Term("x1**3", 1)], [1e9], n_periods=1)
    _, augmented = _sdof([Term("x1**3", 1), Term("boucwen(x1, beta=800, gamma=-1100)", 1)], [1e9, 0.0],
                         n_periods=1)
    assert np.allclose(augmented.displacement, fast.displacement, rtol=0, atol=1e-12 * np.abs(fast.displacement).max())
    with pytest.raises(InputDataError, match="has memory"):
        simulate_response([[1.0]], [[0.0]], [[1.0]], [1], np.zeros(9), 10.0, 2,
                          [Term("boucwen(x1, beta=1, gamma=0)", 1)], [1.0])


def test_the_reference_simulator_agrees_with_the_identification_rule():
    term = Term("boucwen(x1, beta=800, gamma=-1100)", 1)
    errors = []
    for oversample in (10, 20):
        _, response = _sdof([term], [5e4], oversample=oversample, n_periods=1)
        x = response.displacement[:, 0]
        along = 5e4 * boucwen_path(term.expr.memory, x)  # z at 750 Hz from the sampled displacement
        errors.append(np.std(along - response.nonlinear_force[:, 0]) / np.std(response.nonlinear_force[:, 0]))
    assert errors[1] < 0.02  # the straight path between 750 Hz samples (ωΔt = 0.3 at the 36 Hz mode)
    assert abs(errors[0] / errors[1] - 1) < 0.1  # the RK4 state is converged: the rest is the data rate's


def test_one_period_of_a_record_gives_the_periodic_steady_state():
    term = Term("boucwen(x1, beta=800, gamma=-1100)", 1)
    force, response = _sdof([term], [5e4], oversample=10, n_periods=2, period=256)
    last = slice(256, 512)
    one = Signals(force=force.samples[last], displacement=response.displacement[last], fs=750.0, input_dofs=(1,),
                  output_dofs=(1,), period=256)
    column = -extended_input(one, [term])[:, 1]
    assert np.allclose(column, boucwen_periodic(term.expr.memory, response.displacement[last, 0]))
    averaged = -extended_input(one, [term], input_hold="average")[:, 1]
    assert np.allclose(averaged, 0.5 * (column + np.roll(column, -1)))  # trapezoid, closing the period
    record = Signals(force=force.samples, displacement=response.displacement, fs=750.0, input_dofs=(1,),
                     output_dofs=(1,), period=256)
    from_rest = -extended_input(record, [term])[:, 1]
    assert from_rest[0] == 0.0 and np.allclose(from_rest, boucwen_path(term.expr.memory,
                                                                        response.displacement[:, 0]))


def test_the_restoring_force_loop_is_drawn_from_the_record_and_the_steady_loop():
    import matplotlib

    matplotlib.use("Agg")
    from types import SimpleNamespace

    from bayesnsi.curves import hysteresis_loop
    from bayesnsi.plots import plot_hysteresis_loop

    term = Term("boucwen(x1, beta=800, gamma=-1100)", 1)
    force, response = _sdof([term], [5e4], oversample=10, n_periods=1)
    signals = Signals(force=force.samples, displacement=response.displacement, fs=750.0, input_dofs=(1,),
                      output_dofs=(1,))
    step = SimpleNamespace(term=term, coefficient=5e4)
    curve = hysteresis_loop(step, signals)
    assert np.allclose(curve.force, response.nonlinear_force[:, 0][np.isin(response.displacement[:, 0],
                                                                             curve.displacement)], rtol=0.02,
                       atol=0.02 * np.abs(curve.force).max())  # λ z along the record (data-rate rule)
    assert curve.loop_force[0] == pytest.approx(curve.loop_force[-1]) and curve.reading.loop_area > 0
    assert curve.reading.yield_displacement is None  # the benchmark's loading branch hardens
    figure = plot_hysteresis_loop(step, signals, ChannelUnits("N", "m", "m/s"))
    axes = figure.axes[0]
    assert len(axes.lines) == 2 and "hysteretic stiffness" in axes.texts[0].get_text()
    with pytest.raises(InputDataError, match="not a Bouc-Wen term"):
        hysteresis_loop(SimpleNamespace(term=Term("x1**3", 1), coefficient=1.0), signals)
