"""Free bodies with friction: gains in the config, the noise prior's floor, the force residual's evidence, the loop."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.io

from bayesnsi.evidence import candidate_evidence
from bayesnsi.evidence.candidate import candidate_affine, noise_floor_factor
from bayesnsi.exceptions import ConfigError, SpuriousPoleWarning
from bayesnsi.io import dump_config, load_config, load_signals
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.signals import Signals
from tests._helpers.carriage import FC, OFFSET
from tests._helpers.carriage import free_body_record as _free_body_record


def _mat_config(tmp_path, **data):
    rng = np.random.default_rng(0)
    current, position = rng.normal(size=500), np.cumsum(rng.normal(size=500))
    variables = {"vir": current[:, None], "qm": position[:, None], "t": np.arange(500) / 1e3}
    scipy.io.savemat(tmp_path / "axis.mat", variables)
    section = {"file": "axis.mat", "inputs": {"vir": 1}, "outputs": {"qm": 1}, **data}
    path = tmp_path / "axis.toml"
    path.write_text(dump_config({"data": section, "candidates": [{"name": "linear", "terms": []}]}))
    return path, current, position


def test_scale_multiplies_the_named_column(tmp_path):
    path, current, position = _mat_config(tmp_path, scale={"vir": 35.15})
    signals = load_signals(load_config(path))
    np.testing.assert_allclose(signals.force[:, 0], 35.15 * current)
    np.testing.assert_allclose(signals.displacement[:, 0], position)


@pytest.mark.parametrize(
    ("scale", "message"),
    [({"current": 2.0}, "not one of the mapped columns"), ({"vir": 0.0}, "non-zero"), ({"vir": "2"}, "non-zero"),
     ("vir", "inline table")],
)
def test_bad_scale_is_refused_in_one_line(tmp_path, scale, message):
    path, _, _ = _mat_config(tmp_path, scale=scale)
    with pytest.raises(ConfigError, match=message):
        load_config(path)


def test_noise_floor_follows_the_white_noise_level():
    rng = np.random.default_rng(0)
    smooth = np.sin(np.linspace(0, 20, 20000))[:, None]
    precise = smooth + 1e-8 * rng.normal(size=smooth.shape)
    noisy = smooth + 1e-2 * rng.normal(size=smooth.shape)
    # the white-noise level is 1e-8 / std = 1.4e-8: a tenth of it, far below the old 1e-4
    assert noise_floor_factor(precise)[0] == pytest.approx(0.1 * 1e-8 / smooth.std(), rel=0.3)
    assert noise_floor_factor(noisy)[0] == 1e-4  # ordinary noise keeps the former bound
    with pytest.raises(ConfigError, match="noise_floor"):
        EvidenceOptions(noise_floor=20.0)


@pytest.fixture(scope="module")
def carriage() -> Signals:
    q, tau = _free_body_record(duration=30.0)
    return Signals(
        force=(tau - tau.mean())[:, None],
        displacement=(q - q.mean())[:, None],
        fs=200.0,
        input_dofs=(1,),
        output_dofs=(1,),
    )


def test_free_body_evidence_scores_the_force_and_prefers_friction(carriage):
    options = EvidenceOptions(n_walkers=16, n_steps=300, n_burn=100, compare=())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        linear = identify(carriage, None, NSIOptions(block_rows=20, order=2))
        coulomb = identify(carriage, [("sign(v1)", 1)], NSIOptions(block_rows=20, order=2))
        affine = candidate_affine(coulomb, carriage, "innovations")
        # the force residual: measured filtered force, signature sign(v) itself (units of force)
        assert affine.signatures.shape[1:] == (1, 1)
        assert set(np.unique(np.round(affine.signatures[:, 0, 0]))) <= {-1.0, 0.0, 1.0}
        assert affine.estimate[0] == pytest.approx(FC, rel=0.05)
        z_linear = candidate_evidence(linear, carriage, options)["ar1"].log_evidence
        z_coulomb = candidate_evidence(coulomb, carriage, options)["ar1"].log_evidence
    assert np.isfinite(z_linear) and z_coulomb > z_linear + 10


def test_force_screen_ranks_coulomb_first_on_a_free_body(carriage):
    from bayesnsi.loop.screen_force import screen_effects_force
    from bayesnsi.models import CandidateModel, default_gaps, effect_dictionary

    effects = effect_dictionary([1], gaps={(1,): default_gaps(float(carriage.displacement.std()))})
    ranked = screen_effects_force(carriage, CandidateModel(name="linear", terms=()), effects)
    assert ranked[0][0].name == "sign(v)"
    # the look-alikes follow well behind (measured: v|v| and v^3 below half the score)
    scores = dict((e.name, s) for e, s in ranked)
    assert scores["v|v|"] < 0.7 * scores["sign(v)"] and scores["v^3"] < 0.7 * scores["sign(v)"]


def test_loop_on_a_free_body_adds_coulomb_and_nothing_else(carriage):
    from bayesnsi.loop import close_the_loop
    from bayesnsi.models import CandidateModel
    from bayesnsi.options import LoopOptions

    loop = close_the_loop(
        carriage, CandidateModel(name="linear", terms=()), LoopOptions(refine_final=None),
        nsi=NSIOptions(block_rows=20, order=2),
        evidence=EvidenceOptions(n_walkers=16, n_steps=300, n_burn=100, compare=()),
    )
    added = [step.effect.name for step in loop.steps if step.accepted]
    assert added == ["sign(v)"]
    (phys,) = loop.final.physical_parameters
    assert phys.mass == pytest.approx(95.0, rel=0.02) and phys.damping == pytest.approx(200.0, rel=0.05)
    assert loop.final.coefficient_values[0] == pytest.approx(FC, rel=0.05)


def test_loop_whose_scores_all_fail_stops_with_the_reason(carriage, monkeypatch):
    from bayesnsi.exceptions import InputDataError, LoopError
    from bayesnsi.loop import close_the_loop, scoring
    from bayesnsi.models import CandidateModel
    from bayesnsi.options import LoopOptions

    def failing(result, signals, evidence):
        if result.terms:
            raise InputDataError("could not place the walkers (test)")
        return real(result, signals, evidence)

    real = scoring.laplace_score
    monkeypatch.setattr(scoring, "laplace_score", failing)
    with pytest.raises(LoopError, match="could not place the walkers"):
        close_the_loop(
            carriage, CandidateModel(name="linear", terms=()), LoopOptions(refine_final=None, screen=2),
            nsi=NSIOptions(block_rows=20, order=2),
        )


def test_loop_with_a_start_evidence_that_is_not_finite_says_so(carriage, monkeypatch):
    from bayesnsi.exceptions import LoopError
    from bayesnsi.loop import close_the_loop, search
    from bayesnsi.models import CandidateModel

    monkeypatch.setattr(search, "laplace_score", lambda *args: (float("nan"), float("nan")))
    with pytest.raises(LoopError, match="starting model 'linear' is nan"):
        close_the_loop(carriage, CandidateModel(name="linear", terms=()), nsi=NSIOptions(block_rows=20, order=2))


def test_asymmetric_friction_types_act_in_one_direction_and_are_not_default():
    from bayesnsi.models.dictionary import DEFAULT_EFFECT_TYPES, effect_dictionary

    effects = {e.name: e for e in effect_dictionary([1], types=["sign(v)", "sign(v)+", "v+"])}
    v = np.array([[-0.2, -0.1, 0.1, 0.3]])
    x = np.zeros_like(v)
    np.testing.assert_allclose(effects["sign(v)+"].term.evaluate(x, v), [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_allclose(effects["v+"].term.evaluate(x, v), [0.0, 0.0, 0.1, 0.3])
    # Fc+ = 25 N forwards, Fc- = 15 N backwards: λ_sign = 15, λ_sign+ = 10
    force = 15.0 * effects["sign(v)"].term.evaluate(x, v) + 10.0 * effects["sign(v)+"].term.evaluate(x, v)
    np.testing.assert_allclose(force, [-15.0, -15.0, 25.0, 25.0])
    assert "sign(v)+" not in DEFAULT_EFFECT_TYPES and "v+" not in DEFAULT_EFFECT_TYPES
    assert len(effect_dictionary([1])) == len(DEFAULT_EFFECT_TYPES)


def test_validation_of_a_free_body_is_its_force_prediction(carriage):
    from bayesnsi.checks.validation import validate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        coulomb = identify(carriage, [("sign(v1)", 1)], NSIOptions(block_rows=20, order=2))
    (error,) = validate(coulomb, [("second half", carriage.segment(3000, 6000))])
    assert error.quantity == "force" and error.to_dict()["quantity"] == "force"
    assert 0 < error.nrmse < 0.1


def test_physical_table_lists_one_dof_models_with_their_rigid_body_pole(carriage):
    from bayesnsi.tables import physical_table

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        coulomb = identify(carriage, [("sign(v1)", 1)], NSIOptions(block_rows=20, order=2))
    table = physical_table({"Coulomb": coulomb})
    assert table.loc["mass [kg]", "Coulomb"] == pytest.approx(95.0, rel=0.02)
    assert table.loc["rigid-body poles s [1/s]", "Coulomb"] != "-"


def test_offset_is_a_constant_force_read_at_dc():
    from bayesnsi.exceptions import ExpressionError
    from bayesnsi.models import Term
    from bayesnsi.models.dictionary import effect_dictionary
    from bayesnsi.nsi import force_prediction

    assert Term("1", 1).expr.is_constant and not Term("sign(v1)", 1).expr.is_constant
    with pytest.raises(ExpressionError, match="reads no displacement"):
        Term("3*4", 1)  # only a bare number is a constant force
    assert [e.name for e in effect_dictionary([1], types=["offset"])] == ["offset"]
    q, tau = _free_body_record(duration=60.0)
    # the force keeps its mean: the offset (-3 N) is in the data
    signals = Signals(force=tau[:, None], displacement=(q - q.mean())[:, None], fs=200.0, input_dofs=(1,),
                      output_dofs=(1,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        result = identify(signals, [("sign(v1)", 1), ("1", 1)], NSIOptions(block_rows=20, order=2))
        coulomb = identify(signals, [("sign(v1)", 1)], NSIOptions(block_rows=20, order=2))
    fc, offset = result.coefficient_values
    assert fc == pytest.approx(FC, rel=0.03) and offset == pytest.approx(OFFSET, rel=0.03)
    assert result.coefficients[1].imag_ratio < 1e-6  # a real number at DC
    without = force_prediction(coulomb, signals)
    assert force_prediction(result, signals).rmse < without.rmse
