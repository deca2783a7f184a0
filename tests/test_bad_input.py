"""Catalogue of bad inputs: each gets its own error class and a message that says what to do."""

import numpy as np
import pytest

from bayesnsi import CandidateModel, Signals, identify
from bayesnsi.exceptions import (
    BlockRowsError,
    ExpressionError,
    InputDataError,
    NotIdentifiableError,
    OrderError,
    ShapeError,
    UnstableModelError,
)
from bayesnsi.models import parse_expression
from bayesnsi.nsi import StateSpaceModel

RNG = np.random.default_rng(0)
F, X = RNG.standard_normal((400, 1)), RNG.standard_normal((400, 2))


@pytest.mark.parametrize(
    "make, error, message",
    [
        (lambda: Signals(F, np.where(np.arange(800).reshape(400, 2) == 7, np.nan, X), 100, [1], [1, 2]), InputDataError, "NaN/Inf"),
        (lambda: Signals(F, np.c_[X[:, 0], np.inf * X[:, 1]], 100, [1], [1, 2]), InputDataError, "NaN/Inf"),
        (lambda: Signals(F, np.c_[X[:, 0], np.ones(400)], 100, [1], [1, 2]), InputDataError, "constant"),
        (lambda: Signals(F, X[:300], 100, [1], [1, 2]), ShapeError, "same length"),
        (lambda: Signals(F, X, 100, [1], [1, 1]), InputDataError, "repeated"),
        (lambda: Signals(F, X, 100, [1], [0, 1]), InputDataError, "numbered from 1"),
        (lambda: Signals(F, X, 100, [1], [1]), ShapeError, "2 channels"),
        (lambda: Signals(F, X, -1.0, [1], [1, 2]), InputDataError, "sampling frequency"),
        (lambda: Signals(F, X[:, :, None] * np.ones(2), 100, [1], [1, 2]), ShapeError, "n_samples, n_channels"),
    ],
)
def test_bad_signals(make, error, message):
    with pytest.raises(error, match=message):
        make()


@pytest.mark.parametrize("text", ["__import__('os')", "x1.__class__", "lambda: 0", "x1**99999", "open('f')", "[x1]"])
def test_bad_expressions(text):
    with pytest.raises(ExpressionError):
        parse_expression(text)


def _signals():
    return Signals(F, X, 100.0, [1], [1, 2])


def test_identification_errors():
    with pytest.raises(BlockRowsError, match="too few.*use fewer block rows"):
        identify(_signals(), None, block_rows=100)
    with pytest.raises(OrderError, match="lower the order or raise block_rows"):
        identify(_signals(), None, block_rows=5, order=11)
    with pytest.raises(NotIdentifiableError, match="not measured"):
        identify(_signals(), [("x3**3", 1)], block_rows=5, order=2)
    with pytest.raises(NotIdentifiableError, match="cannot be identified"):
        identify(Signals(F, X, 100.0, [1], [1, 2]), [("x1**3", 3)], block_rows=5, order=2)
    with pytest.raises(NotIdentifiableError, match="constant"):
        identify(_signals(), [("x1 - x1", 1)], block_rows=5, order=2)
    with pytest.raises(InputDataError, match="Signals object"):
        identify(np.zeros((10, 2)), None)
    with pytest.raises(InputDataError, match="route"):
        identify(_signals(), None, block_rows=5, route="qr")


def test_unstable_identified_model_is_refused():
    # outputs that grow without bound: no stable underlying linear model explains them
    t = np.arange(400)[:, None]
    growing = np.exp(0.02 * t) * np.c_[np.sin(0.3 * t), np.cos(0.21 * t)] + 1e-3 * X
    with pytest.raises(UnstableModelError, match="unstable"):
        identify(Signals(F, growing, 100.0, [1], [1, 2]), None, block_rows=5, order=2)


def test_unstable_simulation_is_reported():
    model = StateSpaceModel(np.array([[1.5]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 0.01)
    with pytest.raises(UnstableModelError, match="unstable"):
        model.simulate(np.ones((2000, 1)))


def test_empty_candidate_name_and_duplicate_terms():
    from bayesnsi.exceptions import ConfigError

    with pytest.raises(ConfigError, match="non-empty name"):
        CandidateModel(name="", terms=())
    with pytest.raises(ConfigError, match="repeats"):
        CandidateModel.from_terms("m", [("x1", 1), ("x1", 1)])
