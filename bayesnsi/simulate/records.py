"""Records of the simulated cases: :class:`ReferenceCase` (a realisation) and :class:`CaseSetup`.

A :class:`CaseSetup` is everything of a case but the random draws (what a registry entry of
:mod:`bayesnsi.simulate.cases` returns); :func:`bayesnsi.simulate.reference.run_setup` turns it
and a list of seeds into :class:`ReferenceCase` records.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..models.terms import CandidateModel, Term
from ..options import NSIOptions
from ..signals import Signals
from .excitation import Excitation
from .integrate import Response

__all__ = ["ReferenceCase", "CaseSetup"]


@dataclass(frozen=True, eq=False, repr=False)
class ReferenceCase:
    """One simulated reference case of docs/method.md §8.

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
        for averaging λ(ω), docs/method.md §10).
    seed : int or None
        Seed of the realisation (None when a Generator was passed).
    noise_percent : float
        Output noise level [%].
    excitation : Excitation
        The input on both grids (the force, or for the negative-stiffness twin the table
        acceleration [m/s²]).
    settings : dict
        Everything else needed to reproduce the case (oversample, RK4 step, rms, ...).
    title : str
        One-line description.
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

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(self, name=self.name, signals=self.signals, true_model=self.true_model,
                            true_coefficients=tuple(float(c) for c in self.true_coefficients),
                            candidates=tuple(c.name for c in self.candidates), seed=self.seed,
                            noise_percent=self.noise_percent)

    @property
    def n_dofs(self) -> int:
        """Number of DOFs N of the structure."""
        return self.M.shape[0]

    def candidate(self, name: str) -> CandidateModel:
        """The candidate called ``name``.

        Raises
        ------
        KeyError
            If no candidate has that name.
        """
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
class CaseSetup:
    """Everything of a case but the random realisation (what a registry entry returns).

    Attributes
    ----------
    name, title : str
        Registry name and one-line description.
    M, C, K : ndarray, shape (N, N)
        Underlying linear structure [kg, N s/m, N/m].
    terms : tuple of Term
        True nonlinear terms; ``coefficients`` (ndarray, shape (q,)) their λ_i.
    coefficients : ndarray, shape (q,)
        True coefficients.
    true_model : str
        Name of the candidate holding the true terms.
    force_dofs, output_dofs : tuple of int
        DOFs (1-based) of the force and of the measured outputs.
    candidates : tuple of CandidateModel
        Candidate set.
    recommended : NSIOptions
        Suggested NSI settings.
    n_samples : int
        Number of output samples of a realisation.
    excitation : callable
        ``excitation(rng) -> Excitation``, the only random draw before the output noise.
    force_factor : float
        Force [N] = ``force_factor`` × excitation.
    fs : float
        Sampling frequency [Hz].
    oversample : int
        Fine-grid factor of the excitation (the RK4 step is ``2 / (fs · oversample)``).
    settings : dict
        Settings reported by :meth:`ReferenceCase.describe`.
    """

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
    n_samples: int
    excitation: Callable[[np.random.Generator], Excitation]
    force_factor: float
    fs: float
    oversample: int
    settings: dict
