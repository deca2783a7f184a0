"""Simulated cases with an effect the declared model lacks, for closing the loop (docs/method.md §7).

Each case simulates a chain of docs/method.md §8 (the two- or three-DOF chain, RK4 on a band-limited
force, docs/method.md §10) with a set of true nonlinear terms, and *declares* only some of them: the
declared candidate is what a config would state, the missing effects are what
:func:`bayesnsi.loop.close_the_loop` should find (type, location, coefficient). Negative
controls declare the whole truth.

==============================  =========  ==============================  ==================================
name                            chain      declared                        missing (coefficient)
==============================  =========  ==============================  ==================================
``"coulomb-dof2"``              two-DOF    20·v1|v1| @1                    sign(v2) @2 (1 N)
``"cubic-pair"``                three-DOF  none (linear)                   (x1-x2)³ @1-2 (2e5 N/m³)
``"quadratic-damping"``         two-DOF    none (linear)                   v1|v1| @1 (20 N s²/m²)
``"clearance"``                 two-DOF    20·v1|v1| @1                    max(0,|x2|-g)·sign(x2) @2, g = 15 mm
                                                                           (250 N/m)
``"two-missing"``               two-DOF    20·v1|v1| @1                    sign(v2) @2 (1 N) and
                                                                           x1³ @1 (5e5 N/m³)
``"hysteresis"``                two-DOF    none (linear)                   boucwen(x1, β = 150, γ = -50) @1
                                                                           (300 N/m)
``"control-two-dof"``           two-DOF    20·v1|v1| @1                    nothing
``"control-three-dof"``         three-DOF  (x1-x2)³ @1-2                   nothing
``"control-hysteresis"``        two-DOF    300·boucwen(x1, ...) @1         nothing
==============================  =========  ==============================  ==================================

Sizes (measured on seeds 0-4, 30 s, noise-free, by :func:`effect_sizes`: rms of the effect's
force over the rms of the linear restoring force ``(K w)_k`` at its DOF, or of the linear spring
joining the pair): Coulomb at DOF 2 16-18 %, cubic pair 13-17 % (the lightly damped 1.85 Hz mode
of the three-DOF chain makes its amplitude vary, see :func:`~bayesnsi.simulate.three_dof`),
quadratic damping 25-27 %, clearance 21-30 % (|x2| exceeds the gap 33-42 % of the time),
two-missing 16-18 % (Coulomb) and 21-29 % (cubic), hysteresis 31-36 % (the Bouc-Wen element yields
at 10 mm, about the std of x1; it dissipates more than the chain's 1 N s/m dampers).
:func:`effect_sizes` recomputes them for any realisation.

The clearance gap (15 mm) is a round number that is *not* on the loop's default gap grid
(0.5, 1 and 1.5 displacement std, :func:`bayesnsi.models.default_gaps`); the loop has to
refine it (docs/method.md §7: "a clearance on a grid of g").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..exceptions import InputDataError
from ..models.dictionary import clearance_expression
from ..models.expressions import MEMORY
from ..models.terms import CandidateModel, Term
from ..options import NSIOptions
from . import cases as _cases  # noqa: F401  (registers the two- and three-DOF chains)
from .records import ReferenceCase
from .reference import case_setup, run_setup

__all__ = [
    "UNDECLARED_CASES",
    "MissingEffect",
    "UndeclaredCase",
    "effect_sizes",
    "undeclared_case",
    "undeclared_cases",
]

_CLEARANCE_GAP = 0.015  # m
_CLEARANCE_STIFFNESS = 250.0  # N/m


@dataclass(frozen=True)
class MissingEffect:
    """One true effect that the declared candidate lacks.

    Attributes
    ----------
    effect_type : str
        Key of :data:`bayesnsi.models.EFFECT_TYPES`, or ``"clearance"``.
    term : Term
        The true term (expression and location).
    coefficient : float
        Its true coefficient λ.
    gap : float or None
        The clearance gap [m] (clearance only).
    """

    effect_type: str
    term: Term
    coefficient: float
    gap: float | None = None

    @property
    def location(self) -> tuple[int, ...]:
        """DOF ``(k,)`` or pair ``(j, k)`` where the effect acts."""
        return self.term.at

    def matches(self, effect_type: str, term: Term) -> bool:
        """True when ``(effect_type, term)`` of a dictionary has this effect's type and location.

        Clearances match whatever their gap (``"clearance g=..."``); the gap is compared by
        the caller through the coefficient and :attr:`gap`.
        """
        kind = "clearance" if effect_type.startswith("clearance") else effect_type
        return kind == self.effect_type and tuple(term.at) == tuple(self.term.at)

    def describe(self) -> str:
        """E.g. ``"sign(v2) @2 = 1"``."""
        gap = f" (gap {self.gap:g} m)" if self.gap is not None else ""
        return f"{self.effect_type} {self.term.name} = {self.coefficient:g}{gap}"


@dataclass(frozen=True, eq=False)
class UndeclaredCase:
    """A simulated record, the candidate a config declares, and what it lacks (docs/method.md §7).

    Attributes
    ----------
    name : str
        Key of :data:`UNDECLARED_CASES`.
    reference : ReferenceCase
        The simulation (signals, clean signals, full response, true terms and coefficients).
        ``reference.true_terms`` are declared terms first, then the missing ones.
    declared : CandidateModel
        What the config declares (the loop starts from it).
    missing : tuple of MissingEffect
        The effects the declared model lacks; empty for a negative control.
    declared_coefficients : ndarray
        True coefficients of the declared terms.
    nsi : NSIOptions
        NSI settings for :func:`bayesnsi.nsi.identify` (block rows, order).
    """

    name: str
    reference: ReferenceCase
    declared: CandidateModel
    missing: tuple[MissingEffect, ...]
    declared_coefficients: np.ndarray
    nsi: NSIOptions = field(default_factory=NSIOptions)

    @property
    def signals(self):
        """Noisy measured :class:`~bayesnsi.Signals` (estimation data)."""
        return self.reference.signals

    @property
    def clean(self):
        """Noise-free signals."""
        return self.reference.clean

    @property
    def seed(self):
        """Seed of the realisation."""
        return self.reference.seed

    @property
    def noise_percent(self) -> float:
        """Output noise [%] of each channel's std."""
        return self.reference.noise_percent

    @property
    def is_negative_control(self) -> bool:
        """True when nothing is missing."""
        return not self.missing

    @property
    def truth(self) -> CandidateModel:
        """The true model: declared terms followed by the missing ones."""
        return CandidateModel(name="truth", terms=self.declared.terms + tuple(e.term for e in self.missing))

    def describe(self) -> str:
        """Readable summary: the simulation, what is declared and what is missing."""
        declared = ", ".join(t.name for t in self.declared.terms) or "nothing"
        lines = [self.reference.describe(), f"  declared: {declared}"]
        lines.append("  missing: " + ("; ".join(e.describe() for e in self.missing) or "nothing (negative control)"))
        return "\n".join(lines)


_QUAD = ("v|v|", Term("v1*abs(v1)", 1), 20.0)
_COULOMB2 = ("sign(v)", Term("sign(v2)", 2), 1.0)
_CUBIC12_3DOF = ("x^3", Term("(x1-x2)**3", [1, 2]), 2.0e5)
_CUBIC1_2DOF = ("x^3", Term("x1**3", 1), 5.0e5)
_CLEARANCE2 = ("clearance", Term(clearance_expression("x2", _CLEARANCE_GAP), 2), _CLEARANCE_STIFFNESS)
_BOUCWEN1 = (MEMORY, Term("boucwen(x1, beta=150, gamma=-50)", 1), 300.0)  # N/m; yields at 1/(β+γ) = 10 mm

# name -> (title, chain, declared [(type, term, coef)], missing [(type, term, coef)]); the chain is
# the reference case of that name (structure, force and output DOFs, recommended NSI settings)
_DEFINITIONS: dict[str, tuple] = {
    "coulomb-dof2": (
        "Two-DOF chain, declared quadratic damping at DOF 1, undeclared Coulomb friction at DOF 2",
        "two-dof", [_QUAD], [_COULOMB2],
    ),
    "cubic-pair": (
        "Three-DOF chain, declared linear, undeclared cubic spring between DOFs 1 and 2",
        "three-dof", [], [_CUBIC12_3DOF],
    ),
    "quadratic-damping": (
        "Two-DOF chain, declared linear, undeclared quadratic damping at DOF 1",
        "two-dof", [], [_QUAD],
    ),
    "clearance": (
        "Two-DOF chain, declared quadratic damping at DOF 1, undeclared clearance spring at DOF 2",
        "two-dof", [_QUAD], [_CLEARANCE2],
    ),
    "two-missing": (
        "Two-DOF chain, declared quadratic damping at DOF 1, undeclared Coulomb friction at DOF 2 "
        "and cubic spring at DOF 1",
        "two-dof", [_QUAD], [_COULOMB2, _CUBIC1_2DOF],
    ),
    "hysteresis": (
        "Two-DOF chain, declared linear, undeclared Bouc-Wen hysteretic ground spring at DOF 1",
        "two-dof", [], [_BOUCWEN1],
    ),
    "control-two-dof": (
        "Negative control: two-DOF chain, declared = truth (quadratic damping at DOF 1)",
        "two-dof", [_QUAD], [],
    ),
    "control-three-dof": (
        "Negative control: three-DOF chain, declared = truth (cubic spring between DOFs 1 and 2)",
        "three-dof", [_CUBIC12_3DOF], [],
    ),
    "control-hysteresis": (
        "Negative control: two-DOF chain, declared = truth (Bouc-Wen hysteretic ground spring at DOF 1)",
        "two-dof", [_BOUCWEN1], [],
    ),
}

UNDECLARED_CASES: dict[str, str] = {name: spec[0] for name, spec in _DEFINITIONS.items()}
"""Registry: case name -> title."""


def undeclared_case(name: str, seed=0, noise_percent: float = 2.0, **kwargs) -> UndeclaredCase:
    """One seeded realisation of an undeclared-effect case (docs/method.md §7).

    Parameters
    ----------
    name : str
        Key of :data:`UNDECLARED_CASES`.
    seed : int or numpy.random.Generator
        Seed of the force and of the noise.
    noise_percent : float
        Output noise std as a percentage of each channel's std (displacement and velocity).
    **kwargs
        ``duration`` [s] (default 30), ``fs`` [Hz] (100), ``oversample`` (8: RK4 step 2.5 ms),
        ``force_rms`` [N] (10).

    Returns
    -------
    UndeclaredCase
    """
    return undeclared_cases(name, [seed], noise_percent, **kwargs)[0]


def undeclared_cases(
    name: str,
    seeds: Sequence,
    noise_percent: float = 2.0,
    duration: float = 30.0,
    fs: float = 100.0,
    oversample: int = 8,
    force_rms: float = 10.0,
) -> tuple[UndeclaredCase, ...]:
    """Several seeds of one undeclared-effect case, simulated in one batched time loop.

    Parameters
    ----------
    name : str
        Key of :data:`UNDECLARED_CASES`.
    seeds : sequence of int or numpy.random.Generator
    noise_percent : float
        Output noise [%].
    duration, fs, oversample, force_rms
        Record length [s], sampling frequency [Hz], fine-grid factor (even), force rms [N].

    Returns
    -------
    tuple of UndeclaredCase
    """
    if name not in _DEFINITIONS:
        raise InputDataError(f"unknown undeclared-effect case {name!r}; choose one of {sorted(_DEFINITIONS)}")
    title, chain, declared, missing = _DEFINITIONS[name]
    everything = list(declared) + list(missing)
    base = case_setup(chain, duration=duration, fs=fs, oversample=oversample, force_rms=force_rms)
    setup = replace(
        base,
        name=name,
        title=title,
        terms=tuple(t for _, t, _ in everything),
        coefficients=np.array([c for _, _, c in everything], dtype=float),
        true_model="truth",
        candidates=(CandidateModel(name="declared", terms=tuple(t for _, t, _ in declared)),),
        settings={"force_rms_N": force_rms, "duration_s": duration},
    )
    effects = tuple(
        MissingEffect(kind, term, float(coef), _CLEARANCE_GAP if kind == "clearance" else None)
        for kind, term, coef in missing
    )
    return tuple(
        UndeclaredCase(
            name=name,
            reference=ref,
            declared=setup.candidates[0],
            missing=effects,
            declared_coefficients=np.array([c for _, _, c in declared], dtype=float),
            nsi=setup.recommended,
        )
        for ref in run_setup(setup, list(seeds), float(noise_percent))
    )


def effect_sizes(case: UndeclaredCase) -> dict[str, float]:
    """Rms of each missing effect's force over the rms of the linear spring force at its location.

    The reference is, on the noise-free response, the whole linear restoring force ``(K w)_k`` at
    DOF k for a grounded effect, and the force ``k_jk (w_j - w_k)`` of the linear spring joining
    j and k for an effect between them.

    Parameters
    ----------
    case : UndeclaredCase
        A realisation (its noise-free response is used).

    Returns
    -------
    dict term name -> ratio
    """
    resp = case.reference.response
    w = resp.displacement
    out = {}
    for effect in case.missing:
        force = effect.coefficient * effect.term.evaluate(w.T, resp.velocity.T)
        at = effect.term.at
        K = case.reference.K
        if len(at) == 2:
            spring = -K[at[0] - 1, at[1] - 1] * (w[:, at[0] - 1] - w[:, at[1] - 1])
        else:
            spring = w @ K[at[0] - 1]
        out[effect.term.name] = float(np.std(force) / np.std(spring))
    return out
