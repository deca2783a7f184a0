"""The reference cases of docs/method.md §8 as reproducible simulations: one registry entry per case.

Each case is defined once, by a set-up function registered with
:func:`~bayesnsi.simulate.reference.reference_case`: its keyword defaults are the case's
parameters, its body the structure, excitation, true terms and coefficients, candidates and
recommended :class:`~bayesnsi.options.NSIOptions`; the decorator turns it into the public case
function returning a :class:`ReferenceCase` (noisy measured :class:`Signals`, the noise-free
response, the underlying linear matrices, the exact modes and the paper's candidates).
:func:`simulate_cases` runs many seeds of one case in a single batched time loop.

==========================  ================================  ===========================
name                        function                          paper
==========================  ================================  ===========================
``"two-dof"``               :func:`two_dof`                   III.A, Tables 1-4
``"beam"``                  :func:`cantilever_beam_case`      III.B, Tables 5-7
``"negative-stiffness"``    :func:`negative_stiffness_twin`   IV, Eqs. 34-38, Tables 8-10
``"three-dof"``             :func:`three_dof`                 (none: added, paper-style)
==========================  ================================  ===========================
"""

from __future__ import annotations

import numpy as np

from ..models.terms import CandidateModel
from ..options import NSIOptions
from .excitation import band_limited_gaussian
from .reference import CASES, CaseSetup, ReferenceCase, n_samples_of, reference_case, simulate_case, simulate_cases
from .structures import cantilever_beam, chain_system, modal_damping

__all__ = [
    "ReferenceCase",
    "two_dof",
    "cantilever_beam_case",
    "negative_stiffness_twin",
    "negative_stiffness_parameters",
    "three_dof",
    "CASES",
    "simulate_case",
    "simulate_cases",
]

# docs/method.md §8 constants (paper section IV, Table 10 with the consistency fixes of docs/method.md §8)
_K3_TWIN = 7.23e5  # N/m³
_W_LOWER = -0.0301  # m, lower well
_W_UPPER = 0.0242  # m, upper well
_F_TWIN_HZ = 11.4  # Hz, natural frequency about the lower well
_ALPHA1 = 1.16  # N, friction amplitude (multiplies sign(ż)·g)
_ALPHA2 = 4.61  # N s²/m², quadratic damping
_TWIN_TABLE_RMS = 35.0  # m/s², default rms of the white table acceleration (tuned, see docstring)
_K3_THREE_DOF = 2.0e5  # N/m³, cubic spring between DOFs 1 and 2 of the three-DOF case (see three_dof)


def _white_force(n_samples, fs, rms, oversample, band_hz=None):
    """``rng -> Excitation``: band-limited Gaussian excitation of the given rms."""
    return lambda rng: band_limited_gaussian(n_samples, fs, rms, rng, oversample=oversample, band_hz=band_hz)


@reference_case("two-dof", noise_percent=2.0)
def two_dof(duration=10.0, fs=100.0, oversample=8, force_rms=10.0) -> CaseSetup:
    """Two-DOF chain with quadratic damping at DOF 1 (docs/method.md §8, paper III.A).

    Parameters
    ----------
    oversample : int
        Fine-grid factor (even); RK4 step ``2 / (fs * oversample)`` (2.5 ms by default,
        relative RK4 frequency error 2e-6 at 7.5 Hz).
    force_rms : float
        Rms of the white Gaussian force at DOF 2 [N].

    Returns
    -------
    ReferenceCase

    Notes
    -----
    Ground–k1–m1–k2–m2 with m1 = 1, m2 = 1.5 kg, k1 = 800, k2 = 1000 N/m and c1 = c2 = 1
    N s/m (docs/method.md §8: the paper's c = 2 contradicts its own Table 3), plus 20·v1|v1| at DOF 1.
    Gaussian white force of rms 10 N at DOF 2 (trigonometrically interpolated between
    samples). Exact modes 2.46 Hz / 0.91 % and 7.51 Hz / 2.53 %. Candidates (paper Table 2):
    model 1 {v1|v1|} (true), model 2 {sign(v1)}, model 3 {v1|v1|, sign(v1)}.
    """
    M, C, K = chain_system([1.0, 1.5], [800.0, 1000.0], [1.0, 1.0])
    n_samples = n_samples_of(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("v1*abs(v1)", 1)]),
        CandidateModel.from_terms("model 2", [("sign(v1)", 1)]),
        CandidateModel.from_terms("model 3", [("v1*abs(v1)", 1), ("sign(v1)", 1)]),
    )
    return CaseSetup(
        name="two-dof",
        title="Two-DOF chain with quadratic damping (docs/method.md §8, paper III.A)",
        M=M, C=C, K=K,
        terms=cands[0].terms,
        coefficients=np.array([20.0]),
        true_model="model 1",
        force_dofs=(2,), output_dofs=(1, 2),
        candidates=cands,
        recommended=NSIOptions(block_rows=60, order=4),
        n_samples=n_samples,
        excitation=_white_force(n_samples, fs, force_rms, oversample),
        force_factor=1.0,
        fs=fs, oversample=oversample,
        settings={"force_rms_N": force_rms, "c1 = c2 [N s/m]": 1.0},
    )


@reference_case("beam", noise_percent=1.0)
def cantilever_beam_case(duration=100.0, fs=1000.0, oversample=4, force_rms=10.0, damping_ratio=0.01) -> CaseSetup:
    """Cantilever beam with a quadratic + cubic spring at DOF 13 (docs/method.md §8, paper III.B).

    Parameters
    ----------
    oversample : int
        Fine-grid factor (even). The default 4 gives an RK4 step of 0.5 ms and a relative
        frequency error of 2.3e-5 (0.0023 %) at the highest mode, 73.5 Hz; 2 would give
        0.036 %.
    force_rms : float
        Rms of the white Gaussian tip force [N].
    damping_ratio : float
        Modal damping of every mode.

    Returns
    -------
    ReferenceCase

    Notes
    -----
    :func:`cantilever_beam` (8 elements, 16 DOFs, lumped mass), modal damping, force at DOF
    15 (tip w), nonlinear force k2·x13² + k3·x13³ grounded at DOF 13 with k2 = 8e4 N/m²,
    k3 = 4e6 N/m³. Measured: the eight transverse displacements (DOFs 1, 3, ..., 15) and
    their velocities. The linear stiffness seen at DOF 13 is only ≈ 1.5 N/m, so the spring
    has a second well near x13 ≈ -0.02 m and the response is chaotic, hopping between the
    wells (bounded: |x13| < 0.04 m with the defaults). Candidates (paper Table 5): model 1
    {x13|x13|}, model 2 {x13³}, model 3 {x13², x13³} (true).
    """
    M, K = cantilever_beam()
    C = modal_damping(M, K, damping_ratio)
    n_samples = n_samples_of(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("x13*abs(x13)", 13)]),
        CandidateModel.from_terms("model 2", [("x13**3", 13)]),
        CandidateModel.from_terms("model 3", [("x13**2", 13), ("x13**3", 13)]),
    )
    return CaseSetup(
        name="beam",
        title="Cantilever beam with quadratic and cubic stiffness at DOF 13 (docs/method.md §8, paper III.B)",
        M=M, C=C, K=K,
        terms=cands[2].terms,
        coefficients=np.array([8e4, 4e6]),
        true_model="model 3",
        force_dofs=(15,), output_dofs=tuple(range(1, 16, 2)),
        candidates=cands,
        # errors in variables (docs/method.md §10): prediction-error B, C, D and refined in-band poles give
        # k2, k3 within 0.5 %, damping within 5.4 %, frequencies within 0.11 % (seeds 0-7,
        # benchmarks/beam_bias.py); the default output-error B/D is 20-40x faster but k is off by up to 6 %
        recommended=NSIOptions(block_rows=40, order=32, band_hz=(1.0, 30.0), bd_method="prediction-error",
                               refine_poles=(1.5, 85.0), c_method="prediction-error"),
        n_samples=n_samples,
        excitation=_white_force(n_samples, fs, force_rms, oversample),
        force_factor=1.0,
        fs=fs, oversample=oversample,
        settings={
            "force_rms_N": force_rms,
            "modal_damping_ratio": damping_ratio,
            "notes": (
                "chaotic response: x13 hops between the wells near 0 and -0.02 m",
                "the 0.509 Hz mode is hard to identify from 100 s of data",
            ),
        },
    )


@reference_case("negative-stiffness", noise_percent=1.0)
def negative_stiffness_twin(
    duration=140.0, fs=512.0, oversample=6, table_rms=_TWIN_TABLE_RMS, damping_ratio=0.05, band_hz=None
) -> CaseSetup:
    """Simulated twin of the negative-stiffness oscillator (docs/method.md §8, paper IV).

    Parameters
    ----------
    oversample : int
        Fine-grid factor (even); default 6 (RK4 step 0.65 ms). The friction term sign(ż) is
        discontinuous, so RK4 is only first-order accurate across velocity reversals; with
        6 the one-sample local error, written as an equivalent force, is 0.036 N rms on the
        8 % of samples holding a reversal and its projection on sign(ż) is 2.5e-4 N (0.02 %
        of α1, 2 % of the spurious α3 of docs/method.md §10), measured against 128× oversampling.
    table_rms : float
        Rms of the white table acceleration [m/s²]. The default 35 m/s² (force rms ≈ 8 N;
        most of its energy lies far above the 11.4 Hz mode) gives z an std of ≈ 4 mm with
        peaks of 19-22 mm, two thirds of the 30.1 mm way to the barrier; seeds 0-6 stay in
        the lower well for 140 s, seed 7 escapes (25 % of the time beyond the barrier).
        40 m/s² makes 3 of 8 seeds escape; 30 m/s² keeps peaks near 17 mm.
    damping_ratio : float
        Linear viscous damping ratio of the underlying linear system (5 % by default).
    band_hz : (float, float), optional
        Band of the table acceleration; None (default) is white up to fs/2, which keeps
        the input persistently exciting for the subspace step.

    Returns
    -------
    ReferenceCase
        The force channel is the equivalent inertial force ``f = -m a_table(t)`` [N]; the
        table acceleration itself is ``case.excitation``.

    Notes
    -----
    One DOF z = w - w₋ about the lower well (docs/method.md §8)::

        m z̈ + c ż + k1 z + k2 z² + k3 z³ + α1 sign(ż) g(z) + α2 ż|ż| = -m a_table(t)

    with k3 = 7.23e5 N/m³, w₋ = -0.0301 m, w₊ = 0.0242 m, k1 = k3 |w₋| (w₊ - w₋),
    k2 = -k3 (w₊ - 2 w₋) (wells at z = 0 and z = w₊ - w₋, unstable equilibrium at
    z = -w₋), m = k1 / (2π·11.4 Hz)², c = 2 ζ sqrt(k1 m),
    g = (w - w₋)(w - w₊) / (w₋ w₊) = β z² + γ z + δ with β = 1/(w₋ w₊),
    γ = (w₋ - w₊)/(w₋ w₊), δ = 0; α1 = 1.16 N, α2 = 4.61 N s²/m². See
    :func:`negative_stiffness_parameters` for the numbers. Candidates (paper Table 8), all
    with x1² and x1³: model 1 adds the α1 term, model 2 the α1 term and v1|v1| (true),
    model 3 the α1 term and sign(v1), model 4 all three.
    """
    p = negative_stiffness_parameters(damping_ratio)
    M, C, K = np.array([[p["m"]]]), np.array([[p["c"]]]), np.array([[p["k1"]]])
    friction = f"sign(v1)*({p['beta']:.12g}*x1**2+{p['gamma']:.12g}*x1)"
    base = [("x1**2", 1), ("x1**3", 1), (friction, 1)]
    cands = (
        CandidateModel.from_terms("model 1", base),
        CandidateModel.from_terms("model 2", base + [("v1*abs(v1)", 1)]),
        CandidateModel.from_terms("model 3", base + [("sign(v1)", 1)]),
        CandidateModel.from_terms("model 4", base + [("v1*abs(v1)", 1), ("sign(v1)", 1)]),
    )
    n_samples = n_samples_of(duration, fs)
    return CaseSetup(
        name="negative-stiffness",
        title="Negative-stiffness oscillator twin (docs/method.md §8, paper IV)",
        M=M, C=C, K=K,
        terms=cands[1].terms,
        coefficients=np.array([p["k2"], p["k3"], p["alpha1"], p["alpha2"]]),
        true_model="model 2",
        force_dofs=(1,), output_dofs=(1,),
        candidates=cands,
        # upsample 4 (block rows on the fine grid): sign() friction resolved between the 512 Hz
        # samples; α1 error -2.1 % -> within 0.8 % (benchmarks/upsample.py, seeds 0-3)
        recommended=NSIOptions(block_rows=80, order=2, band_hz=(5.0, 20.0), upsample=4),
        n_samples=n_samples,
        excitation=_white_force(n_samples, fs, table_rms, oversample, band_hz),
        force_factor=-p["m"],
        fs=fs, oversample=oversample,
        settings={
            "table_rms_m_s2": table_rms,
            "mass_kg": p["m"],
            "linear_damping_N_s_m": p["c"],
            "linear_damping_ratio": damping_ratio,
            "k1_N_m": p["k1"],
            "beta, gamma, delta": (p["beta"], p["gamma"], p["delta"]),
            "notes": (
                "force column = equivalent inertial force -m*a_table [N]; "
                "the table acceleration [m/s^2] is case.excitation",
                "z = w - w_lower: wells at z = 0 and z = w_upper - w_lower, barrier at z = -w_lower",
            ),
        },
    )


@reference_case("three-dof", noise_percent=2.0)
def three_dof(duration=20.0, fs=100.0, oversample=8, force_rms=10.0) -> CaseSetup:
    """Three-DOF chain with a cubic spring between DOFs 1 and 2 (not in the paper; paper-style).

    Parameters
    ----------
    oversample : int
        Fine-grid factor (even); RK4 step ``2 / (fs * oversample)`` (2.5 ms by default, as
        for :func:`two_dof`; highest mode 7.94 Hz).
    force_rms : float
        Rms of the white Gaussian force at DOF 3 [N].

    Returns
    -------
    ReferenceCase

    Notes
    -----
    Ground–k1–m1–k2–m2–k3–m3 with m = (1, 1.5, 1.2) kg, k = (800, 1000, 900) N/m and
    c = (1, 1, 1) N s/m (dampers in parallel with the springs), plus the cubic spring
    k_nl·(x1 - x2)³ acting between DOFs 1 and 2 (term ``(x1-x2)**3`` at ``[1, 2]``) with
    k_nl = 2e5 N/m³. Exact linear modes 1.848 Hz / 0.67 %, 5.493 Hz / 1.97 %,
    7.943 Hz / 2.66 %. Gaussian white force of rms 10 N at DOF 3; all three DOFs measured
    (displacement and velocity).

    Size of the nonlinearity (measured over seeds 0-15 with the defaults): the relative
    displacement x1 - x2 has an std of ≈ 15 mm (peaks ≈ 40 mm), so the rms of the cubic force
    is ≈ 14 % of the rms of the linear spring force k2·(x1 - x2) (6-31 % between seeds: the
    lightly damped 1.85 Hz mode makes the amplitude vary from record to record);
    k_nl·std² / k2 ≈ 5 %.

    Candidates: model 1 {(x1-x2)³ at [1, 2]} (true), model 2 {x1³ at 1}, model 3
    {v1|v1| at 1}, model 4 {(x1-x2)³ at [1, 2], x1³ at 1} (a superset of the true model).
    """
    M, C, K = chain_system([1.0, 1.5, 1.2], [800.0, 1000.0, 900.0], [1.0, 1.0, 1.0])
    n_samples = n_samples_of(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("(x1-x2)**3", [1, 2])]),
        CandidateModel.from_terms("model 2", [("x1**3", 1)]),
        CandidateModel.from_terms("model 3", [("v1*abs(v1)", 1)]),
        CandidateModel.from_terms("model 4", [("(x1-x2)**3", [1, 2]), ("x1**3", 1)]),
    )
    return CaseSetup(
        name="three-dof",
        title="Three-DOF chain with a cubic spring between DOFs 1 and 2 (paper-style, not in the paper)",
        M=M, C=C, K=K,
        terms=cands[0].terms,
        coefficients=np.array([_K3_THREE_DOF]),
        true_model="model 1",
        force_dofs=(3,), output_dofs=(1, 2, 3),
        candidates=cands,
        recommended=NSIOptions(block_rows=40, order=6),
        n_samples=n_samples,
        excitation=_white_force(n_samples, fs, force_rms, oversample),
        force_factor=1.0,
        fs=fs, oversample=oversample,
        settings={"force_rms_N": force_rms, "c1 = c2 = c3 [N s/m]": 1.0},
    )


def negative_stiffness_parameters(damping_ratio: float = 0.05) -> dict:
    """Physical parameters of the negative-stiffness twin (docs/method.md §8).

    Parameters
    ----------
    damping_ratio : float
        Linear viscous damping ratio about the lower well.

    Returns
    -------
    dict
        ``m`` [kg], ``c`` [N s/m], ``k1`` [N/m], ``k2`` [N/m²], ``k3`` [N/m³], ``w_lower``,
        ``w_upper`` [m], ``beta`` [1/m²], ``gamma`` [1/m], ``delta`` [-], ``alpha1`` [N],
        ``alpha2`` [N s²/m²], ``frequency_hz``, ``damping_ratio``.
    """
    k3, wl, wu = _K3_TWIN, _W_LOWER, _W_UPPER
    k1 = k3 * abs(wl) * (wu - wl)
    k2 = -k3 * (wu - 2 * wl)
    m = k1 / (2 * np.pi * _F_TWIN_HZ) ** 2
    c = 2 * damping_ratio * np.sqrt(k1 * m)
    prod = wl * wu
    return {
        "m": m,
        "c": c,
        "k1": k1,
        "k2": k2,
        "k3": k3,
        "w_lower": wl,
        "w_upper": wu,
        "beta": 1.0 / prod,
        "gamma": (wl - wu) / prod,
        "delta": 0.0,
        "alpha1": _ALPHA1,
        "alpha2": _ALPHA2,
        "frequency_hz": _F_TWIN_HZ,
        "damping_ratio": damping_ratio,
    }
