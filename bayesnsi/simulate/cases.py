"""The reference cases of SPEC 8 as reproducible simulations.

Each case function returns a :class:`ReferenceCase`: noisy measured :class:`Signals`
(force, displacement and velocity at the measured DOFs), the noise-free response, the
underlying linear matrices, the true nonlinear terms and coefficients, the exact modes and
the paper's candidate models. :func:`simulate_cases` runs many seeds of one case in a single
batched time loop.

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

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..exceptions import InputDataError
from ..models.terms import CandidateModel, Term
from ..options import NSIOptions
from ..signals import Signals
from .excitation import Excitation, band_limited_gaussian
from .integrate import Response, add_output_noise, simulate_response
from .structures import cantilever_beam, chain_system, modal_damping, modal_parameters

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

# SPEC 8.3 constants (paper section IV, Table 10 with SPEC's consistency fixes)
_K3_TWIN = 7.23e5  # N/m³
_W_LOWER = -0.0301  # m, lower well
_W_UPPER = 0.0242  # m, upper well
_F_TWIN_HZ = 11.4  # Hz, natural frequency about the lower well
_ALPHA1 = 1.16  # N, friction amplitude (multiplies sign(ż)·g)
_ALPHA2 = 4.61  # N s²/m², quadratic damping
_TWIN_TABLE_RMS = 35.0  # m/s², default rms of the white table acceleration (tuned, see docstring)
_K3_THREE_DOF = 2.0e5  # N/m³, cubic spring between DOFs 1 and 2 of the three-DOF case (see three_dof)


@dataclass(frozen=True, eq=False)
class ReferenceCase:
    """One simulated reference case of SPEC 8.

    Attributes
    ----------
    name : str
        Registry name (``"two-dof"``, ``"beam"``, ``"negative-stiffness"``, ``"three-dof"``).
    signals : Signals
        Measured data: force [N] at ``input_dofs``, noisy displacement [m] and noisy velocity
        [m/s] at ``output_dofs`` (noise std = ``noise_percent`` % of each channel's std,
        drawn independently for displacement and velocity).
    clean : Signals
        The same channels without noise.
    response : Response
        The full noise-free response (all DOFs, acceleration, nonlinear force).
    M, C, K : ndarray, shape (N, N)
        Underlying linear system [kg, N s/m, N/m].
    true_terms : tuple of Term
        The nonlinear terms used in the simulation.
    true_coefficients : ndarray, shape (q,)
        Their coefficients λ_i, in the order of ``true_terms``.
    true_model : str
        Name of the candidate whose terms are ``true_terms``.
    exact_frequencies_hz, exact_damping_ratios : ndarray
        Modes of the underlying linear system (:func:`modal_parameters`).
    candidates : tuple of CandidateModel
        The paper's candidate set, in the paper's order ("model 1", ...).
    recommended : NSIOptions
        Suggested NSI settings: ``block_rows``, ``order`` and ``band_hz`` (a frequency band
        for averaging λ(ω), SPEC 10).
    seed : int or None
        Seed of the realisation (None when a Generator was passed).
    noise_percent : float
        Output noise level [%].
    excitation : Excitation
        The input on both grids (the force, or for the negative-stiffness twin the table
        acceleration [m/s²]).
    settings : dict
        Everything else needed to reproduce the case (oversample, RK4 step, rms, ...).
    """

    name: str
    signals: Signals
    clean: Signals
    response: Response
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    true_terms: tuple[Term, ...]
    true_coefficients: np.ndarray
    true_model: str
    exact_frequencies_hz: np.ndarray
    exact_damping_ratios: np.ndarray
    candidates: tuple[CandidateModel, ...]
    recommended: NSIOptions
    seed: int | None
    noise_percent: float
    excitation: Excitation
    settings: Mapping[str, Any] = field(default_factory=dict)
    title: str = ""

    @property
    def n_dofs(self) -> int:
        """Number of DOFs N of the structure."""
        return self.M.shape[0]

    def candidate(self, name: str) -> CandidateModel:
        """The candidate called ``name``."""
        for cand in self.candidates:
            if cand.name == name:
                return cand
        raise KeyError(f"no candidate {name!r}; have {[c.name for c in self.candidates]}")

    def describe(self) -> str:
        """A readable summary of the case and its true parameters."""
        sig = self.signals
        lines = [
            f"{self.title or self.name} (case {self.name!r}, seed {self.seed})",
            f"  {self.n_dofs} DOFs; force at DOF {', '.join(map(str, sig.input_dofs))}; "
            f"measured displacement and velocity at DOF {', '.join(map(str, sig.output_dofs))}",
            f"  {sig.n_samples} samples at {sig.fs:g} Hz ({sig.n_samples / sig.fs:g} s), "
            f"output noise {self.noise_percent:g} % of each channel's std",
            "  true nonlinear terms (" + self.true_model + "):",
        ]
        for term, coef in zip(self.true_terms, self.true_coefficients):
            lines.append(f"    {coef:.6g} * {term.expr.canonical}  at DOF {term.at_value}")
        modes = ", ".join(
            f"{f:.4g} Hz/{100 * z:.3g} %" for f, z in zip(self.exact_frequencies_hz, self.exact_damping_ratios)
        )
        lines.append(f"  exact linear modes: {modes}")
        lines.append("  candidates:")
        for cand in self.candidates:
            lines.append(f"    {cand.name}: " + ", ".join(t.name for t in cand.terms))
        lines.append("  recommended: " + ", ".join(f"{k}={v}" for k, v in self.recommended.to_dict().items()))
        for key, value in self.settings.items():
            if key != "notes":
                lines.append(f"  {key}: {value}")
        for note in self.settings.get("notes", ()):
            lines.append(f"  note: {note}")
        return "\n".join(lines)


@dataclass(frozen=True)
class _Setup:
    """Everything of a case but the random realisation."""

    name: str
    title: str
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    terms: tuple[Term, ...]
    coefficients: np.ndarray
    true_model: str
    force_dofs: tuple[int, ...]
    output_dofs: tuple[int, ...]
    candidates: tuple[CandidateModel, ...]
    recommended: NSIOptions
    make_excitation: Callable[[np.random.Generator], Excitation]
    force_factor: float  # force [N] = force_factor * excitation
    fs: float
    oversample: int
    settings: dict


def two_dof(
    seed=0,
    noise_percent: float = 2.0,
    duration: float = 10.0,
    fs: float = 100.0,
    oversample: int = 8,
    force_rms: float = 10.0,
) -> ReferenceCase:
    """Two-DOF chain with quadratic damping at DOF 1 (SPEC 8.1, paper III.A).

    Parameters
    ----------
    seed : int or numpy.random.Generator
        Seed of the force and the noise.
    noise_percent : float
        Output noise std as a percentage of each channel's std.
    duration : float
        Record length [s].
    fs : float
        Sampling frequency [Hz].
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
    N s/m (SPEC 8.1: the paper's c = 2 contradicts its own Table 3), plus 20·v1|v1| at DOF 1.
    Gaussian white force of rms 10 N at DOF 2 (trigonometrically interpolated between
    samples). Exact modes 2.46 Hz / 0.91 % and 7.51 Hz / 2.53 %. Candidates (paper Table 2):
    model 1 {v1|v1|} (true), model 2 {sign(v1)}, model 3 {v1|v1|, sign(v1)}.
    """
    return simulate_cases(
        "two-dof", [seed], noise_percent, duration=duration, fs=fs, oversample=oversample, force_rms=force_rms
    )[0]


def cantilever_beam_case(
    seed=0,
    noise_percent: float = 1.0,
    duration: float = 100.0,
    fs: float = 1000.0,
    oversample: int = 4,
    force_rms: float = 10.0,
    damping_ratio: float = 0.01,
) -> ReferenceCase:
    """Cantilever beam with a quadratic + cubic spring at DOF 13 (SPEC 8.2, paper III.B).

    Parameters
    ----------
    seed : int or numpy.random.Generator
        Seed of the force and the noise.
    noise_percent : float
        Output noise std as a percentage of each channel's std.
    duration : float
        Record length [s].
    fs : float
        Sampling frequency [Hz].
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
    return simulate_cases(
        "beam",
        [seed],
        noise_percent,
        duration=duration,
        fs=fs,
        oversample=oversample,
        force_rms=force_rms,
        damping_ratio=damping_ratio,
    )[0]


def negative_stiffness_twin(
    seed=0,
    noise_percent: float = 1.0,
    duration: float = 140.0,
    fs: float = 512.0,
    oversample: int = 6,
    table_rms: float = _TWIN_TABLE_RMS,
    damping_ratio: float = 0.05,
    band_hz=None,
) -> ReferenceCase:
    """Simulated twin of the negative-stiffness oscillator (SPEC 8.3, paper IV).

    Parameters
    ----------
    seed : int or numpy.random.Generator
        Seed of the table acceleration and the noise.
    noise_percent : float
        Output noise std as a percentage of each channel's std.
    duration : float
        Record length [s].
    fs : float
        Sampling frequency [Hz].
    oversample : int
        Fine-grid factor (even); default 6 (RK4 step 0.65 ms). The friction term sign(ż) is
        discontinuous, so RK4 is only first-order accurate across velocity reversals; with
        6 the one-sample local error, written as an equivalent force, is 0.036 N rms on the
        8 % of samples holding a reversal and its projection on sign(ż) is 2.5e-4 N (0.02 %
        of α1, 2 % of the spurious α3 of SPEC 10), measured against 128× oversampling.
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
    One DOF z = w - w₋ about the lower well (SPEC 8.3)::

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
    return simulate_cases(
        "negative-stiffness",
        [seed],
        noise_percent,
        duration=duration,
        fs=fs,
        oversample=oversample,
        table_rms=table_rms,
        damping_ratio=damping_ratio,
        band_hz=band_hz,
    )[0]


def three_dof(
    seed=0,
    noise_percent: float = 2.0,
    duration: float = 20.0,
    fs: float = 100.0,
    oversample: int = 8,
    force_rms: float = 10.0,
) -> ReferenceCase:
    """Three-DOF chain with a cubic spring between DOFs 1 and 2 (not in the paper; paper-style).

    Parameters
    ----------
    seed : int or numpy.random.Generator
        Seed of the force and the noise.
    noise_percent : float
        Output noise std as a percentage of each channel's std.
    duration : float
        Record length [s].
    fs : float
        Sampling frequency [Hz].
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
    return simulate_cases(
        "three-dof", [seed], noise_percent, duration=duration, fs=fs, oversample=oversample, force_rms=force_rms
    )[0]


def negative_stiffness_parameters(damping_ratio: float = 0.05) -> dict:
    """Physical parameters of the negative-stiffness twin (SPEC 8.3).

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


def simulate_case(name: str, seed=0, noise_percent: float | None = None, **kwargs) -> ReferenceCase:
    """Run the reference case called ``name`` (a key of :data:`CASES`).

    Parameters
    ----------
    name : {"two-dof", "beam", "negative-stiffness", "three-dof"}
    seed : int or numpy.random.Generator
    noise_percent : float, optional
        Output noise [%]; the case's default when None.
    **kwargs
        Further keyword arguments of the case function (duration, fs, oversample, ...).
    """
    function = _lookup(name)
    if noise_percent is not None:
        kwargs["noise_percent"] = noise_percent
    return function(seed=seed, **kwargs)


def simulate_cases(
    name: str, seeds: Sequence, noise_percent: float | None = None, **kwargs
) -> tuple[ReferenceCase, ...]:
    """Run several seeds of one case in one batched time loop.

    Parameters
    ----------
    name : {"two-dof", "beam", "negative-stiffness", "three-dof"}
    seeds : sequence of int or numpy.random.Generator
        One realisation per seed; each is identical (to rounding) to ``simulate_case(name,
        seed)``.
    noise_percent : float, optional
        Output noise [%]; the case's default when None.
    **kwargs
        Further keyword arguments of the case function.

    Returns
    -------
    tuple of ReferenceCase
    """
    _lookup(name)
    seeds = list(seeds)
    if not seeds:
        raise InputDataError("simulate_cases needs at least one seed")
    defaults = _DEFAULT_NOISE[name]
    noise = defaults if noise_percent is None else float(noise_percent)
    setup = _SETUPS[name](**kwargs)
    return _run(setup, seeds, noise)


# --------------------------------------------------------------------------------------
# case set-ups


def _two_dof_setup(duration=10.0, fs=100.0, oversample=8, force_rms=10.0):
    M, C, K = chain_system([1.0, 1.5], [800.0, 1000.0], [1.0, 1.0])
    n_samples = _n_samples(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("v1*abs(v1)", 1)]),
        CandidateModel.from_terms("model 2", [("sign(v1)", 1)]),
        CandidateModel.from_terms("model 3", [("v1*abs(v1)", 1), ("sign(v1)", 1)]),
    )
    return _Setup(
        name="two-dof",
        title="Two-DOF chain with quadratic damping (SPEC 8.1, paper III.A)",
        M=M,
        C=C,
        K=K,
        terms=cands[0].terms,
        coefficients=np.array([20.0]),
        true_model="model 1",
        force_dofs=(2,),
        output_dofs=(1, 2),
        candidates=cands,
        recommended=NSIOptions(block_rows=60, order=4),
        make_excitation=lambda rng: band_limited_gaussian(n_samples, fs, force_rms, rng, oversample=oversample),
        force_factor=1.0,
        fs=fs,
        oversample=oversample,
        settings={"force_rms_N": force_rms, "c1 = c2 [N s/m]": 1.0},
    )


def _beam_setup(duration=100.0, fs=1000.0, oversample=4, force_rms=10.0, damping_ratio=0.01):
    M, K = cantilever_beam()
    C = modal_damping(M, K, damping_ratio)
    n_samples = _n_samples(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("x13*abs(x13)", 13)]),
        CandidateModel.from_terms("model 2", [("x13**3", 13)]),
        CandidateModel.from_terms("model 3", [("x13**2", 13), ("x13**3", 13)]),
    )
    return _Setup(
        name="beam",
        title="Cantilever beam with quadratic and cubic stiffness at DOF 13 (SPEC 8.2, paper III.B)",
        M=M,
        C=C,
        K=K,
        terms=cands[2].terms,
        coefficients=np.array([8e4, 4e6]),
        true_model="model 3",
        force_dofs=(15,),
        output_dofs=tuple(range(1, 16, 2)),
        candidates=cands,
        # errors in variables (SPEC 10): prediction-error B, C, D and refined in-band poles give
        # k2, k3 within 0.5 %, damping within 3.6 %, frequencies within 0.1 % (seeds 0-7,
        # benchmarks/beam_bias.py); the default output-error B/D is 20-40x faster but k is off by up to 6 %
        recommended=NSIOptions(block_rows=40, order=32, band_hz=(1.0, 30.0), bd_method="prediction-error",
                               refine_poles=(1.5, 85.0), c_method="prediction-error"),
        make_excitation=lambda rng: band_limited_gaussian(n_samples, fs, force_rms, rng, oversample=oversample),
        force_factor=1.0,
        fs=fs,
        oversample=oversample,
        settings={
            "force_rms_N": force_rms,
            "modal_damping_ratio": damping_ratio,
            "notes": (
                "chaotic response: x13 hops between the wells near 0 and -0.02 m",
                "the 0.509 Hz mode is hard to identify from 100 s of data",
            ),
        },
    )


def _twin_setup(
    duration=140.0,
    fs=512.0,
    oversample=6,
    table_rms=_TWIN_TABLE_RMS,
    damping_ratio=0.05,
    band_hz=None,
):
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
    n_samples = _n_samples(duration, fs)
    return _Setup(
        name="negative-stiffness",
        title="Negative-stiffness oscillator twin (SPEC 8.3, paper IV)",
        M=M,
        C=C,
        K=K,
        terms=cands[1].terms,
        coefficients=np.array([p["k2"], p["k3"], p["alpha1"], p["alpha2"]]),
        true_model="model 2",
        force_dofs=(1,),
        output_dofs=(1,),
        candidates=cands,
        # upsample 4 (block rows on the fine grid): sign() friction resolved between the 512 Hz
        # samples; α1 error -2.1 % -> within 0.8 % (benchmarks/upsample.py, seeds 0-3)
        recommended=NSIOptions(block_rows=80, order=2, band_hz=(5.0, 20.0), upsample=4),
        make_excitation=lambda rng: band_limited_gaussian(
            n_samples, fs, table_rms, rng, oversample=oversample, band_hz=band_hz
        ),
        force_factor=-p["m"],
        fs=fs,
        oversample=oversample,
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


def _three_dof_setup(duration=20.0, fs=100.0, oversample=8, force_rms=10.0):
    M, C, K = chain_system([1.0, 1.5, 1.2], [800.0, 1000.0, 900.0], [1.0, 1.0, 1.0])
    n_samples = _n_samples(duration, fs)
    cands = (
        CandidateModel.from_terms("model 1", [("(x1-x2)**3", [1, 2])]),
        CandidateModel.from_terms("model 2", [("x1**3", 1)]),
        CandidateModel.from_terms("model 3", [("v1*abs(v1)", 1)]),
        CandidateModel.from_terms("model 4", [("(x1-x2)**3", [1, 2]), ("x1**3", 1)]),
    )
    return _Setup(
        name="three-dof",
        title="Three-DOF chain with a cubic spring between DOFs 1 and 2 (paper-style, not in the paper)",
        M=M,
        C=C,
        K=K,
        terms=cands[0].terms,
        coefficients=np.array([_K3_THREE_DOF]),
        true_model="model 1",
        force_dofs=(3,),
        output_dofs=(1, 2, 3),
        candidates=cands,
        recommended=NSIOptions(block_rows=40, order=6),
        make_excitation=lambda rng: band_limited_gaussian(n_samples, fs, force_rms, rng, oversample=oversample),
        force_factor=1.0,
        fs=fs,
        oversample=oversample,
        settings={"force_rms_N": force_rms, "c1 = c2 = c3 [N s/m]": 1.0},
    )


_SETUPS: dict[str, Callable[..., _Setup]] = {
    "two-dof": _two_dof_setup,
    "beam": _beam_setup,
    "negative-stiffness": _twin_setup,
    "three-dof": _three_dof_setup,
}
_DEFAULT_NOISE = {"two-dof": 2.0, "beam": 1.0, "negative-stiffness": 1.0, "three-dof": 2.0}

CASES: dict[str, Callable[..., ReferenceCase]] = {
    "two-dof": two_dof,
    "beam": cantilever_beam_case,
    "negative-stiffness": negative_stiffness_twin,
    "three-dof": three_dof,
}
"""Registry of the reference cases: name -> case function."""


def _run(setup: _Setup, seeds: list, noise_percent: float) -> tuple[ReferenceCase, ...]:
    if not (np.isfinite(noise_percent) and noise_percent >= 0):
        raise InputDataError(f"noise_percent must be a non-negative number, got {noise_percent!r}")
    rngs = [np.random.default_rng(s) for s in seeds]
    excitations = [setup.make_excitation(rng) for rng in rngs]
    force_fine = np.stack([e.fine for e in excitations]) * setup.force_factor
    response = simulate_response(
        setup.M,
        setup.C,
        setup.K,
        setup.force_dofs,
        force_fine,
        setup.fs * setup.oversample,
        setup.oversample,
        setup.terms,
        setup.coefficients,
    )
    freqs, zetas = modal_parameters(setup.M, setup.C, setup.K)
    cols = [d - 1 for d in setup.output_dofs]
    settings_common = {
        "oversample": setup.oversample,
        "rk4_step_s": response.step,
        "simulation_wall_time_s": response.elapsed_s,
        "batch_size": len(seeds),
    }
    cases = []
    for b, (seed, rng, exc) in enumerate(zip(seeds, rngs, excitations)):
        single = _pick(response, b)
        force = exc.samples * setup.force_factor
        disp, vel = single.displacement[:, cols], single.velocity[:, cols]
        noisy_disp = add_output_noise(disp, noise_percent, rng)
        noisy_vel = add_output_noise(vel, noise_percent, rng)
        common = dict(fs=setup.fs, input_dofs=setup.force_dofs, output_dofs=setup.output_dofs)
        cases.append(
            ReferenceCase(
                name=setup.name,
                signals=Signals(force=force, displacement=noisy_disp, velocity=noisy_vel, **common),
                clean=Signals(force=force, displacement=disp, velocity=vel, **common),
                response=single,
                M=setup.M,
                C=setup.C,
                K=setup.K,
                true_terms=setup.terms,
                true_coefficients=setup.coefficients.copy(),
                true_model=setup.true_model,
                exact_frequencies_hz=freqs,
                exact_damping_ratios=zetas,
                candidates=setup.candidates,
                recommended=setup.recommended,
                seed=int(seed) if isinstance(seed, (int, np.integer)) else None,
                noise_percent=noise_percent,
                excitation=exc,
                settings={**setup.settings, **settings_common},
                title=setup.title,
            )
        )
    return tuple(cases)


def _pick(response: Response, b: int) -> Response:
    if response.displacement.ndim == 2:
        return response
    return Response(
        displacement=response.displacement[b],
        velocity=response.velocity[b],
        acceleration=response.acceleration[b],
        nonlinear_force=response.nonlinear_force[b],
        force=response.force[b],
        fs=response.fs,
        step=response.step,
        n_steps=response.n_steps,
        elapsed_s=response.elapsed_s,
    )


def _n_samples(duration: float, fs: float) -> int:
    if not (np.isfinite(duration) and duration > 0 and np.isfinite(fs) and fs > 0):
        raise InputDataError(f"duration and fs must be positive numbers, got {duration!r} s and {fs!r} Hz")
    n = int(round(duration * fs))
    if n < 10:
        raise InputDataError(f"{duration} s at {fs} Hz gives only {n} samples; lengthen the record")
    return n


def _lookup(name: str):
    if name not in CASES:
        raise InputDataError(f"unknown case {name!r}; choose one of {sorted(CASES)}")
    return CASES[name]
