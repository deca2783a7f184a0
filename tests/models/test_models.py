"""Candidate-term language: safe parsing (SPEC 9), evaluation, locations."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesnsi.exceptions import BayesNSIError, ConfigError, ExpressionError
from bayesnsi.models import CandidateModel, Term, nonlinear_force, parse_expression


@pytest.mark.parametrize(
    "text, expected",
    [
        ("v1*abs(v1)", lambda x, v: v[0] * np.abs(v[0])),
        ("x13**3", lambda x, v: x[12] ** 3),
        ("(x3-x4)**3", lambda x, v: (x[2] - x[3]) ** 3),
        ("sign(v1)*(-1372.8*x1**2+74.5*x1)", lambda x, v: np.sign(v[0]) * (-1372.8 * x[0] ** 2 + 74.5 * x[0])),
        ("-x1**2", lambda x, v: -(x[0] ** 2)),
        ("tanh(10*v2)/2 + 1e-3*x1", lambda x, v: np.tanh(10 * v[1]) / 2 + 1e-3 * x[0]),
        ("abs(x1)**1.5", lambda x, v: np.abs(x[0]) ** 1.5),
        ("2**-1*x1", lambda x, v: 0.5 * x[0]),
    ],
)
def test_expressions_evaluate_like_numpy(text, expected, rng):
    x, v = rng.standard_normal((13, 50)), rng.standard_normal((13, 50))
    np.testing.assert_allclose(parse_expression(text).evaluate(x, v), expected(x, v), rtol=1e-14)


@pytest.mark.parametrize(
    "text, message",
    [
        ("__import__('os')", "unknown name"),
        ("x1.real", "unexpected character"),
        ("lambda: x1", "unknown name"),
        ("x1**1000", "outside"),
        ("x1**x2", "constant"),
        ("open('f')", "unknown name"),
        ("x0", "numbered from 1"),
        ("x1 x2", "unexpected"),
        ("", "empty"),
        ("3*4", "reads no displacement"),
        ("(x1", "expected '\\)'"),
        ("x1;", "unexpected character"),
        ("x1" + "+x1" * 200, "characters long"),
        ("(" * 50 + "x1" + ")" * 50, "nests deeper"),
    ],
)
def test_invalid_expressions_are_refused(text, message):
    with pytest.raises(ExpressionError, match=message):
        parse_expression(text)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=60))
def test_parser_fuzz_gives_expression_or_expression_error(text):
    try:
        expr = parse_expression(text)
    except ExpressionError:
        return
    x = np.linspace(-1, 1, 4 * 20).reshape(20, 4)
    assert expr.evaluate(x, x).shape == (4,)


_TOKENS = ["x1", "v2", "abs(", "sign(", "tanh(", ")", "+", "-", "*", "/", "**", "2", "0.5"]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from(_TOKENS), max_size=15))
def test_parser_fuzz_on_grammar_tokens(tokens):
    try:
        parse_expression("".join(tokens))
    except ExpressionError:
        pass


def test_term_locations_and_force():
    grounded, element = Term("x1**3", 1), Term("(x1-x2)**3", (1, 2))
    np.testing.assert_array_equal(grounded.location_vector(3), [1, 0, 0])
    np.testing.assert_array_equal(element.location_vector(3), [1, -1, 0])
    x, v = np.array([[0.2], [0.1], [0.0]]), np.zeros((3, 1))
    force = nonlinear_force([grounded, element], [10.0, 100.0], x, v, 3)
    np.testing.assert_allclose(force[:, 0], [10 * 0.008 + 100 * 0.001, -100 * 0.001, 0.0])
    with pytest.raises(ExpressionError, match="two different DOFs"):
        Term("x1", (2, 2))
    with pytest.raises(ExpressionError):
        Term("x1", "one")


def test_candidate_model_validation():
    cand = CandidateModel.from_terms("m", [("v1*abs(v1)", 1)], prior=0.5)
    assert cand.n_terms == 1 and cand.terms[0].name == "v1*abs(v1)@1"
    bigger = cand.with_term(Term("x1**3", 1))
    assert bigger.n_terms == 2 and cand.n_terms == 1
    with pytest.raises(ConfigError, match="repeats"):
        CandidateModel.from_terms("m", [("x1", 1), ("x1", 1)])
    with pytest.raises(ConfigError, match="prior"):
        CandidateModel.from_terms("m", [("x1", 1)], prior=-1)
    assert issubclass(ExpressionError, BayesNSIError) and issubclass(ExpressionError, ValueError)


@pytest.mark.parametrize(
    "first, second",
    [
        (("x1**3", 1), ("x1*x1*x1", 1)),  # one function written twice: the coefficient would be split in two
        (("x1**3", 1), ("-2.5*x1**3", 1)),  # a constant factor
        (("(x1-x2)**3", [1, 2]), ("(x1-x2)**3", [2, 1])),  # the same element, location reversed
        (("v1*abs(v1)", 1), ("abs(v1)*v1", 1)),
    ],
)
def test_collinear_terms_are_refused(first, second):
    with pytest.raises(ConfigError, match=r"terms .*@.* and .*@.* are the same function up to a constant factor"):
        CandidateModel.from_terms("m", [first, second])


@pytest.mark.parametrize(
    "first, second",
    [
        (("x1**3", 1), ("x1**3", 2)),  # other location
        (("x1**3", 1), ("x1**3 + x1", 1)),  # differs only for small displacements
        (("x1**16", 1), ("x1**16 + x1", 1)),
        (("sign(v1)", 1), ("tanh(1000*v1)", 1)),  # differs only for small velocities
        (("x1**3", 1), ("v1**3", 1)),
        (("abs(x1)", 1), ("x1", 1)),
    ],
)
def test_independent_terms_are_accepted(first, second):
    assert CandidateModel.from_terms("m", [first, second]).n_terms == 2


@pytest.mark.parametrize(
    "expr, switches",
    [
        ("sign(v1)", True),
        ("x1*sign(v2-v1)", True),
        ("(x1**2)*sign(v1)", True),
        ("(((abs(x1)-0.01)*(sign(abs(x1)-0.01)+1))/2)*sign(x1)", False),  # clearance: continuous force
        ("v1*abs(v1)", False),
        ("tanh(v1)", False),
        ("sign(x1)*v1", False),
    ],
)
def test_switches_with_velocity_flags_sign_of_a_velocity(expr, switches):
    assert parse_expression(expr).switches_with_velocity is switches
