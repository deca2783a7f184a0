"""Free-free two-mass rig: a free body that is not a single carriage.

Two carriages on rails joined by a spring and a damper, no spring and no damper to ground, force
on mass 1, Coulomb friction on mass 2, both positions measured (encoder-like noise). The record is
built here by an independent fine-step semi-implicit Euler integration; the reference values are
the simulated parameters: elastic mode f = √(k(1/m1 + 1/m2))/2π, ζ = c ω/(2k), Fc.

The virtual spring's mode of a body with no damping to ground is undamped and its estimate may fall
just outside the unit circle: the true candidate must identify (:mod:`bayesnsi.nsi._virtual_mode`),
and the rigid-body double pole must not be reported as a 0.004 Hz mode.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import AdequacyWarning, OrderWarning, SpuriousPoleWarning
from bayesnsi.findings import messages
from bayesnsi.nsi import identify
from bayesnsi.nsi.free_body import rigid_body_poles
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals

M1, M2, K, C, FC2 = 2.0, 1.5, 4000.0, 4.0, 1.5
FS, SUB = 500.0, 20
OMEGA = np.sqrt(K * (1 / M1 + 1 / M2))
F_TRUE, ZETA_TRUE = OMEGA / (2 * np.pi), C * OMEGA / (2 * K)


def _band_limited(rng, n, fs, lo, hi, rms):
    spec = np.zeros(n // 2 + 1, complex)
    f = np.fft.rfftfreq(n, 1 / fs)
    sel = (f >= lo) & (f <= hi)
    spec[sel] = np.exp(1j * rng.uniform(0, 2 * np.pi, sel.sum()))
    x = np.fft.irfft(spec, n)
    return x * rms / x.std()


def _two_mass_record(seed: int = 1, duration: float = 30.0, noise: float = 1e-6):
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    h = 1 / (FS * SUB)
    t = np.arange(n * SUB) * h
    force = _band_limited(rng, n * SUB, FS * SUB, 1.0, 40.0, 10.0) + 1.5 * np.sin(2 * np.pi * 0.5 * t)
    x1 = x2 = v1 = v2 = 0.0
    f_out, x_out = np.empty(n), np.empty((n, 2))
    for k in range(n * SUB):
        spring = K * (x1 - x2) + C * (v1 - v2)
        if k % SUB == 0:
            f_out[k // SUB], x_out[k // SUB] = force[k], (x1, x2)
        v1 += h * (force[k] - spring) / M1
        v2 += h * (spring - FC2 * np.sign(v2)) / M2
        x1 += h * v1
        x2 += h * v2
    x_out += rng.normal(0.0, noise, x_out.shape)
    return Signals(force=f_out[:, None], displacement=x_out, fs=FS, input_dofs=(1,), output_dofs=(1, 2))


@pytest.mark.parametrize("noise", [1e-6, 1e-4])  # position noise [m]: 1 µm (encoder), 0.1 mm (0.1 % of std)
def test_free_free_true_candidate_identifies(noise):
    rig = _two_mass_record(noise=noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # a real pole of the rigid body (0.1 mm noise)
        result = identify(rig, [("sign(v2)", 2)], NSIOptions())
    assert result.virtual_stiffness > 0
    # the rigid-body double pole is reported as rigid, not as a mode (with 0.1 mm noise one of the
    # two estimates is a real pole at -0.48 rad/s, which the record resolves: a spurious pole)
    assert len(result.rigid_body_poles) == (2 if noise < 1e-5 else 1)
    (mode,) = result.modes
    assert mode.frequency_hz == pytest.approx(F_TRUE, rel=0.005)
    assert mode.damping_ratio == pytest.approx(ZETA_TRUE, rel=0.1)
    assert result.coefficient_values[0] == pytest.approx(FC2, rel=0.05 if noise < 1e-5 else 0.1)


def test_slow_complex_pair_counts_as_rigid():
    dt, n = 0.002, 30000  # 60 s: 2π/T = 0.105 rad/s
    s = np.array([-0.021 + 0.016j, -0.021 - 0.016j, -2.35 + 68.3j, -2.35 - 68.3j, -0.5 + 3j])
    rigid = rigid_body_poles(np.exp(s * dt), dt, n)
    assert len(rigid) == 2
    assert np.allclose(np.sort_complex(rigid), np.sort_complex(s[:2]))


def test_only_the_virtual_mode_is_mirrored():
    from bayesnsi.nsi._virtual_mode import mirror_undamped, physical_mirrored
    from bayesnsi.nsi.physics import Mode

    dt = 0.002
    # one lightly unstable pair (ζ = -0.036 at 0.93 Hz) and a stable one: mirrored, same frequency
    s = np.array([0.21 + 5.84j, 0.21 - 5.84j, -2.35 + 68.3j, -2.35 - 68.3j])
    z1, z2 = np.exp(s[0] * dt), np.exp(s[2] * dt)
    A_real = np.zeros((4, 4))
    A_real[:2, :2] = [[z1.real, z1.imag], [-z1.imag, z1.real]]  # real block of the pair z, conj(z)
    A_real[2:, 2:] = [[z2.real, z2.imag], [-z2.imag, z2.real]]
    stable, mirrored = mirror_undamped(A_real, dt)
    assert np.max(np.abs(np.linalg.eigvals(stable))) < 1.0
    assert len(mirrored) == 1 and abs(np.angle(mirrored[0])) / (2 * np.pi * dt) == pytest.approx(5.84 / (2 * np.pi))
    # a strongly unstable pair (ζ = -0.5) or a real unstable pole is not mirrored
    assert mirror_undamped(np.diag([np.exp(0.5 * dt)] * 2), dt) is None
    # the free model still has a mode at the mirrored frequency: a physical mode, reported
    elastic = Mode(frequency_hz=0.93, damping_ratio=0.01, pole=complex(-0.06, 5.84))
    assert physical_mirrored(mirrored, [elastic], dt) == [pytest.approx(0.929, rel=1e-3)]
    assert physical_mirrored(mirrored, [], dt) == []


def _affine(rng, n, rho, q=1, sigma=0.5):
    from bayesnsi.nsi import AffineReconstruction

    g = np.cumsum(rng.standard_normal((n, 1, q)), axis=0) / np.sqrt(n)  # slow signatures
    noise = np.empty((n, 1))
    noise[0] = sigma * rng.standard_normal(1)
    for k in range(1, n):
        noise[k] = rho * noise[k - 1] + sigma * rng.standard_normal(1)
    if rho == 1.0:  # integrated twice, as a force error is in the position of a drifting free body
        noise = np.cumsum(noise, axis=0)
    baseline = rng.standard_normal((n, 1))
    measured = baseline + g @ np.ones(q) + noise
    ls = np.linalg.lstsq(g.reshape(-1, q), (measured - baseline).reshape(-1), rcond=None)[0]
    return AffineReconstruction(measured=measured, baseline=baseline, signatures=g, estimate=ls, names=("k",) * q)


def _priors(affine):
    from bayesnsi.evidence.priors import CoefficientPrior, NoisePrior, Priors

    q = affine.signatures.shape[2]
    return Priors(coefficients=CoefficientPrior(affine.names, np.full(q, 3.0)),
                  noise=NoisePrior.from_std(affine.measured.std(axis=0)))


def test_loop_evidence_of_a_random_walk_residual_is_finite():
    """AR(1) mode beyond the prior bound: Laplace over every parameter is NaN, the collapsed one
    matches the exact evidence (closed form: λ analytically, σ and ρ by quadrature)."""
    from bayesnsi.evidence import closed_form_log_evidence, laplace_log_evidence, sufficient_statistics
    from bayesnsi.evidence.boundary import collapsed_laplace_log_evidence

    rng = np.random.default_rng(5)
    affine = _affine(rng, 4000, rho=1.0)
    stats, priors = sufficient_statistics(affine, ar_order=1), _priors(affine)
    assert np.isnan(laplace_log_evidence(stats, priors, "ar1"))
    exact = closed_form_log_evidence(stats, priors, "ar1")
    assert collapsed_laplace_log_evidence(stats, priors, "ar1") == pytest.approx(exact, abs=0.1)
    # where the full Laplace is finite the two agree
    affine = _affine(rng, 4000, rho=0.5)
    stats, priors = sufficient_statistics(affine, ar_order=1), _priors(affine)
    full = laplace_log_evidence(stats, priors, "ar1")
    assert collapsed_laplace_log_evidence(stats, priors, "ar1") == pytest.approx(full, abs=0.05)


def _write_acc_case(folder, acc, force, fs, band):
    lines = ["f1,a1,a2"] + [f"{f:.9g},{a:.9g},{b:.9g}" for f, (a, b) in zip(force, acc)]
    (folder / "acc.csv").write_text("\n".join(lines) + "\n")
    (folder / "acc.toml").write_text(
        f'[data]\nfile = "acc.csv"\nfs = {fs}\ninputs = {{ f1 = 1 }}\naccelerations = {{ a1 = 1, a2 = 2 }}\n'
        f"integrate = {{ band_hz = [{band[0]}, {band[1]}] }}\n"
        '[[candidates]]\nname = "linear"\nterms = []\n'
    )
    return folder / "acc.toml"


def test_accelerometers_on_a_free_body_warn(tmp_path):
    """Integrated accelerations lose the rigid-body motion below f_lo: the loader says so."""
    from bayesnsi.exceptions import IntegrationWarning
    from bayesnsi.io import load_config, load_signals

    rig = _two_mass_record(duration=20.0)
    x = np.asarray(rig.displacement)
    acc = (x[2:] - 2 * x[1:-1] + x[:-2]) * FS**2  # the rig's accelerations (noise-free positions)
    config = _write_acc_case(tmp_path, acc, np.asarray(rig.force)[1:-1, 0], FS, (2.0, 100.0))
    with pytest.warns(IntegrationWarning, match=r"below the integration band.*mass line"):
        load_signals(load_config(config))


def test_accelerometers_on_a_grounded_structure_do_not_warn(tmp_path):
    """A two-DOF chain held by springs (modes 4.4 and 11.5 Hz), broadband force: nothing lost."""
    from scipy.signal import lsim

    from bayesnsi.io import load_config, load_signals

    rng = np.random.default_rng(3)
    m, k, c = np.diag([1.0, 1.0]), np.array([[2e3, -1e3], [-1e3, 1e3]]) * 2, np.array([[2.0, -1.0], [-1.0, 1.0]])
    a_c = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    b_c = np.concatenate([np.zeros((2, 1)), np.linalg.solve(m, [[1.0], [0.0]])])
    fs, n = 100.0, 6000
    force = _band_limited(rng, n, fs, 0.0, 40.0, 1.0)
    t = np.arange(n) / fs
    _, _, states = lsim((a_c, b_c, np.eye(4), np.zeros((4, 1))), force, t)
    acc = states @ a_c[2:].T + force[:, None] * b_c[2:, 0]
    config = _write_acc_case(tmp_path, acc, force, fs, (1.0, 40.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_signals(load_config(config))


def _carriage_record(seed: int = 2, duration: float = 30.0, noise: float = 1e-6):
    """One carriage (M 20 kg, Fv 30 N s/m, Fc 8 N) in a PD position loop, as the EMPS axis."""
    rng = np.random.default_rng(seed)
    n, h = int(duration * FS), 1 / (FS * SUB)
    t = np.arange(n * SUB) * h
    ref = sum(0.006 * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in rng.uniform(0.2, 1.5, 5))
    disturbance = _band_limited(rng, n * SUB, FS * SUB, 0.1, 60.0, 10.0)
    q = v = tau = 0.0
    qs, taus = np.empty(n), np.empty(n)
    for k in range(n * SUB):
        if k % SUB == 0:
            tau = 2.0e4 * (ref[k] - q) - 800.0 * v + disturbance[k]
            qs[k // SUB], taus[k // SUB] = q, tau
        v += h * (tau - 30.0 * v - 8.0 * np.sign(v)) / 20.0
        q += h * v
    qs += rng.normal(0.0, noise, n)
    return Signals(force=(taus - taus.mean())[:, None], displacement=(qs - qs.mean())[:, None], fs=FS,
                   input_dofs=(1,), output_dofs=(1,))


def test_carriage_with_a_wrong_velocity_term_is_identified_as_a_free_body():
    """v|v| instead of sign(v): the first estimate has two real stable poles (no mode); it failed
    with "no physical mode" instead of taking the free-body route (virtual spring)."""
    carriage = _carriage_record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the carriage
        warnings.simplefilter("ignore", OrderWarning)  # "auto" takes order 2 of a one-mass carriage
        wrong = identify(carriage, [("v1*abs(v1)", 1)], NSIOptions())
        right = identify(carriage, [("sign(v1)", 1)], NSIOptions())
    assert wrong.virtual_stiffness > 0 and right.virtual_stiffness > 0
    (phys,) = right.physical_parameters
    assert (phys.mass, phys.damping, right.coefficient_values[0]) == pytest.approx((20.0, 30.0, 8.0), rel=0.05)


def test_selection_says_when_a_derived_velocity_is_mostly_noise():
    """0.1 mm position noise at 500 Hz: v2's difference noise is 0.34 of its std (sign(v2) read on noise)."""
    from bayesnsi.checks.velocity_noise import velocity_noise_findings
    from bayesnsi.models import CandidateModel

    coulomb = CandidateModel.from_terms("Coulomb at 2", [("sign(v2)", 2)])
    noisy = _two_mass_record(duration=10.0, noise=1e-4)
    (message,) = messages(velocity_noise_findings(noisy, [coulomb]))
    assert "v2" in message and "sign(v2)" in message and "measure the velocity" in message
    assert messages(velocity_noise_findings(_two_mass_record(duration=10.0, noise=1e-6), [coulomb])) == ()
    measured = Signals(force=noisy.force, displacement=noisy.displacement, velocity=noisy.velocities(), fs=FS,
                       input_dofs=(1,), output_dofs=(1, 2))
    assert messages(velocity_noise_findings(measured, [coulomb])) == ()


def _carriage_candidates():
    from bayesnsi.models import CandidateModel

    return [CandidateModel.from_terms("linear", []), CandidateModel.from_terms("Coulomb", [("sign(v1)", 1)]),
            CandidateModel.from_terms("cubic", [("x1**3", 1)])]


def test_select_scores_every_candidate_of_a_free_body_on_the_force():
    """Coulomb identifies as a free body, linear and x³ as grounded oscillators: their log Z (force
    residual against displacement residual) were ranked together and x³ was selected (seed 2)."""
    from bayesnsi import select
    from bayesnsi.nsi import is_free_body
    from bayesnsi.options import EvidenceOptions

    carriage = _carriage_record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)  # the order notes and no adequate candidate
        selection = select(carriage, _carriage_candidates(), NSIOptions(), EvidenceOptions(interval="posterior"))
    assert all(is_free_body(o.result) for o in selection.outcomes)
    assert selection.selected == "Coulomb"
    assert any("identified again with its virtual spring" in f.message for f in selection.findings)


def test_loop_from_a_grounded_looking_start_switches_to_the_free_body_view():
    """From linear (no rigid-body pole) sign(v1) identifies as a free body: the loop compared its
    force log Z with the start's displacement log Z (log BF -2.6e5) and added nothing (seed 2)."""
    from bayesnsi.loop import close_the_loop
    from bayesnsi.options import LoopOptions

    carriage = _carriage_record()
    loop = close_the_loop(carriage, _carriage_candidates()[0], LoopOptions(refine_final=None), nsi=NSIOptions())
    assert [s.term.name for s in loop.steps if s.accepted] == ["sign(v1)@1"]
    assert loop.start.virtual_stiffness > 0
    assert loop.final.coefficient_values[0] == pytest.approx(8.0, rel=0.05)


def test_diagnose_lines_name_a_free_bodys_validation_error_as_force_prediction():
    """A free body is validated by the force it predicts, not by a closed-loop simulation."""
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.options import LoopOptions
    from bayesnsi.report.terminal import diagnosis_lines

    before = (SimpleNamespace(name="second record", nrmse=0.411, quantity="force"),)
    after = (SimpleNamespace(name="second record", nrmse=0.0957, quantity="force"),)
    step = SimpleNamespace(accepted=True, term=Term("sign(v1)", 1), reason="", imag_ratio=0.02, log_bayes_factor=9.0,
                           effect=SimpleNamespace(name="sign(v)", location=(1,)))
    loop = SimpleNamespace(steps=(step,), scores=(), options=LoopOptions(), friction=None,
                           final=SimpleNamespace(coefficients=()), final_nsi=SimpleNamespace(upsample=1),
                           nsi=SimpleNamespace(upsample=1))
    final = SimpleNamespace(check=None, intervals=None, result=SimpleNamespace(coefficients=()),
                            validation_before=before, validation=after)
    diagnosis = SimpleNamespace(loop=loop, added=(step,), start="linear", final=final,
                                selection=SimpleNamespace(checks={}, signals=None))
    assert "  validation second record: force-prediction NRMSE 0.411 -> 0.0957" in diagnosis_lines(diagnosis)


def test_residual_force_of_a_free_body_has_the_size_of_the_effect():
    """The restoring-force view mapped the residual through the free FRF, whose rigid-body 1/ω²
    set the Tikhonov load: the 1.5 N friction showed as 0.0014 N (std) in the report."""
    from bayesnsi.loop.forces import residual_force

    rig = _two_mass_record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the rig
        after = identify(rig, [("sign(v2)", 2)], NSIOptions())
        before = identify(rig, None, NSIOptions(virtual_stiffness=after.virtual_stiffness))
    view = residual_force(before, after, rig, after.terms[0])
    lam = after.coefficient_values[0]
    assert 0.3 * lam < view.effect.std() < lam  # sign(v2) has std 1; the filter keeps most of it
    assert view.after.std() < 0.1 * view.before.std()


def test_report_names_the_rigid_body_poles_of_a_free_body_with_several_dofs():
    from types import SimpleNamespace

    from bayesnsi.report.sections import _rigid_body_note

    results = {"Coulomb at 2": SimpleNamespace(rigid_body_poles=np.array([-0.021 + 0.016j, -0.021 - 0.016j])),
               "linear": SimpleNamespace(rigid_body_poles=np.array([0.0214 + 0j]))}
    note = _rigid_body_note(results)
    assert note.startswith("Rigid-body poles s [1/s]")
    assert "Coulomb at 2: -0.021+0.016j, -0.021-0.016j; linear: 0.0214." in note


def test_rigid_body_pole_of_a_carriage_is_reported_on_a_long_record():
    """60 s: the rigid-body pole's estimate (-0.12 rad/s) is above 2π/T = 0.105 but far below the
    band (0.76-1.67 Hz): a rigid-body pole, not a spurious one; the viscous pole (-Fv/M) stays apart."""
    dt, n = 0.002, 30000
    s = np.array([-0.1235, -1.473])
    assert len(rigid_body_poles(np.exp(s * dt), dt, n)) == 0  # the record length alone
    assert np.allclose(rigid_body_poles(np.exp(s * dt), dt, n, (0.76, 1.67)), [-0.1235])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the carriage
        result = identify(_carriage_record(seed=1, duration=60.0), [("sign(v1)", 1)], NSIOptions())
    assert len(result.rigid_body_poles) == 1
    assert abs(result.rigid_body_poles[0]) < 0.1 * 30.0 / 20.0  # well below the viscous pole Fv/M = 1.5 rad/s


def test_loop_step_of_a_free_body_with_several_dofs_has_short_horizon_errors():
    """Open-loop simulation of the free-free rig drifts; the step documents 1 s windows instead
    (they were computed for one-DOF free bodies only: NaN here)."""
    from bayesnsi.loop.guards import documented
    from bayesnsi.loop.results import LoopStep
    from bayesnsi.models import effect_dictionary

    rig = _two_mass_record(duration=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the rig
        after = identify(rig, [("sign(v2)", 2)], NSIOptions())
        before = identify(rig, None, NSIOptions(virtual_stiffness=after.virtual_stiffness))
    effect = next(e for e in effect_dictionary([1, 2], types=["sign(v)"]) if e.term.name == "sign(v2)@2")
    step = LoopStep(effect=effect, accepted=True, reason="accepted", coefficient=after.coefficient_values[0],
                    ci95=(1.4, 1.6), imag_ratio=0.1, half_coefficients=(1.5, 1.5), log_bayes_factor=100.0,
                    nrmse_before=0.02, nrmse_after=0.01, candidate=after.candidate)
    step = documented(step, before, after, rig)
    assert step.short_horizon_nrmse_after < 0.5 * step.short_horizon_nrmse_before


def test_identify_command_gives_every_candidate_of_a_free_body_the_same_view(tmp_path, capsys):
    import json

    from bayesnsi.cli import main

    carriage = _carriage_record()
    rows = np.column_stack([np.asarray(carriage.force)[:, 0], np.asarray(carriage.displacement)[:, 0]])
    np.savetxt(tmp_path / "rec.csv", rows, delimiter=",", header="tau,q", comments="", fmt="%.9g")
    (tmp_path / "c.toml").write_text(
        f'[data]\nfile = "rec.csv"\nfs = {FS}\ninputs = {{ tau = 1 }}\noutputs = {{ q = 1 }}\n'
        '[[candidates]]\nname = "linear"\nterms = []\n'
        '[[candidates]]\nname = "Coulomb"\nterms = [{ expr = "sign(v1)", at = 1 }]\n')
    assert main(["identify", str(tmp_path / "c.toml"), "--out", str(tmp_path / "out"), "--no-figures", "--quiet"]) == 0
    records = json.loads((tmp_path / "out" / "results.json").read_text())["candidates"]
    assert all(r["virtual_stiffness"] > 0 for r in records)
    assert "identified again with its virtual spring" in capsys.readouterr().err


def test_select_does_not_widen_a_free_free_bodys_intervals_by_the_virtual_modes_ringing():
    """The stabilised model's open-loop residual rings at the undamped virtual mode (1100x the noise
    for the true model): widening by that ratio made Coulomb 1.48 N read [-42, 45] N, 'not supported'."""
    from bayesnsi import select
    from bayesnsi.models import CandidateModel
    from bayesnsi.options import EvidenceOptions

    rig = _two_mass_record(duration=20.0)
    candidates = [CandidateModel.from_terms("Coulomb at 2", [("sign(v2)", 2)]),
                  CandidateModel.from_terms("Coulomb at 1", [("sign(v1)", 1)])]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)  # no adequate candidate: the intervals are tested
        selection = select(rig, candidates, NSIOptions(), EvidenceOptions(n_replicates=4))
    (interval,) = selection.outcome("Coulomb at 2").intervals.coefficients
    assert 0 < interval.ci95[0] < FC2 * 1.1 and interval.ci95[1] < 2 * FC2
    assert not any("sign(v2)@2 is not supported" in f.message for f in selection.findings)
