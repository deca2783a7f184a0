"""The loop's fixed context (data, dictionary, settings) and its state (model, steps, scores)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .._measured import measured_error
from ..nsi import is_free_body, nrmse
from ..options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions
from .results import EffectScore, LoopStep

__all__ = ["Baseline", "LoopContext", "LoopState"]


@dataclass(frozen=True)
class LoopContext:
    """What stays fixed during one loop.

    Attributes
    ----------
    signals : Signals
        Estimation data.
    effects : tuple of Effect
        The dictionary.
    nsi : NSIOptions
    evidence : EvidenceOptions
        Scores the loop's residual (``LoopOptions.residual``) with the primary likelihood only.
    options : LoopOptions
    execution : ExecutionOptions
        ``jobs`` local worker processes or a Dask ``scheduler`` that score the effects of a search.
    screen_hz : float or None
        Highest frequency of the frequency-domain screen; None when the screen is off.
    """

    signals: Any
    effects: tuple
    nsi: NSIOptions
    evidence: EvidenceOptions
    options: LoopOptions
    execution: ExecutionOptions = field(default_factory=ExecutionOptions)
    screen_hz: float | None = None


@dataclass(frozen=True)
class Baseline:
    """The model an effect is checked against: its Laplace log-evidence and open-loop NRMSE."""

    log_evidence: float
    nrmse: float


def _imag_ratio(result) -> float:
    """Quality index of the last (the added effect's) coefficient of ``result``; NaN without one."""
    if result is None or not result.coefficients:
        return float("nan")
    return float(result.coefficients[-1].imag_ratio)


def _seed_stream(seed: int) -> Iterator[np.random.SeedSequence]:
    """Children of ``SeedSequence(seed)``, one at a time, as many as needed."""
    sequence = np.random.SeedSequence(seed)
    while True:
        yield sequence.spawn(1)[0]


@dataclass
class LoopState:
    """What the search changes: the current model, the checked steps, the scores, the seeds.

    Attributes
    ----------
    current : NSIResult
        The current model.
    log_z : float
        Its Laplace log-evidence.
    steps : list of LoopStep
        Every checked effect, in the order checked (accepted ones are replaced in place when
        they are documented, removed or exchanged).
    scores : list of tuple of EffectScore
        The scores of each search.
    added : list of (str, tuple of int)
        ``(base type, location)`` of each effect added: not proposed again.
    half_cache : dict
        Hankel products of the record halves per base model (stability guard).
    """

    current: Any
    log_z: float
    seed: int
    steps: list[LoopStep] = field(default_factory=list)
    scores: list[tuple[EffectScore, ...]] = field(default_factory=list)
    added: list[tuple[str, tuple[int, ...]]] = field(default_factory=list)
    half_cache: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._seeds = _seed_stream(self.seed)

    def next_seed(self) -> np.random.SeedSequence:
        """The seed of the next effect checked (one per check, in order)."""
        return next(self._seeds)

    def record_scores(self, scored, log_z: float) -> int:
        """Keep a search's scores (without the identified models); returns the search's index.

        ``log_z`` is the Laplace log-evidence of the model the search started from (each
        score's ``log_bayes_factor``); the quality index is read from each enlarged model.
        """
        self.scores.append(tuple(
            replace(s, result=None, log_bayes_factor=float(s.log_evidence - log_z), imag_ratio=_imag_ratio(s.result))
            for s in scored
        ))
        return len(self.scores) - 1

    def replace_step(self, old: LoopStep, new: LoopStep) -> LoopStep:
        """Put ``new`` in the place of ``old`` (same object) in :attr:`steps`; returns ``new``."""
        self.steps[next(i for i, s in enumerate(self.steps) if s is old)] = new
        return new

    def mark_added(self, step: LoopStep) -> None:
        """Exclude the type and location of ``step``'s effect from later searches."""
        self.added.append((step.effect.base, step.effect.location))

    def baseline(self, signals) -> Baseline:
        """The current model, on ``signals``, as the baseline of the next check."""
        if is_free_body(self.current):  # the force-prediction error (IDIM view), as the effects report
            from ..nsi import force_affine

            affine = force_affine(self.current, signals)
            return Baseline(self.log_z, float(nrmse(affine.measured, affine.predict(affine.estimate))[1]))
        return Baseline(self.log_z, measured_nrmse(self.current.reconstruct(signals), signals))


def measured_nrmse(reconstruction, signals) -> float:
    """NRMSE of a reconstruction in the quantity the sensors measured (``Signals.measured``).

    Displacements: the paper's NRMSE of the reconstruction itself. Velocities or accelerations
    (integrated by ``[data] integrate``): both displacements differentiated back alike
    (:func:`bayesnsi._measured.measured_error`), so a loop step's errors read in the measured units.

    Parameters
    ----------
    reconstruction : Reconstruction
        Open- or closed-loop reconstruction of ``signals``.
    signals : Signals

    Returns
    -------
    float
    """
    if getattr(signals, "measured", "displacement") == "displacement":
        return float(reconstruction.nrmse)
    return measured_error(reconstruction.measured, reconstruction.predicted, signals).nrmse
