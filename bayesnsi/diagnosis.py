"""Closing the loop as one library call: from a selection to the model it lacks (docs/method.md §7).

:func:`diagnose` takes what :func:`bayesnsi.select` returned, closes the loop from one of its
candidates (:func:`bayesnsi.loop.close_the_loop`), and gives the final model everything a candidate
of the selection has: its evidence, its honest intervals (the linear part's uncertainty included,
widened by its model error when it is not adequate), its adequacy check, and its closed-loop errors
on the held-out segments before and after. The command line's ``bayesnsi diagnose``, the
workflows and results.json are built from the :class:`Diagnosis` it returns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .checks.adequacy import ModelCheck
from .checks.residual_bands import band_findings
from .checks.validation import SegmentError, validate
from .exceptions import AdequacyWarning, BayesNSIError, ConfigError, require
from .findings import Finding, emit
from .loop import LoopResult, close_the_loop, loop_effects
from .options import ExecutionOptions, LoopOptions
from .selection import Selection

if TYPE_CHECKING:
    from .evidence import EvidenceResult
    from .loop import LoopStep
    from .nsi import NSIResult
    from .uncertainty import Intervals

__all__ = ["Diagnosis", "FinalModel", "diagnose"]


@dataclass(frozen=True)
class FinalModel:
    """The model the loop ends with, checked as a candidate of the selection is.

    Attributes
    ----------
    result : NSIResult
        Its identification (re-identified on a finer grid when it holds a term that switches with
        velocity: ``LoopResult.final_nsi``).
    evidence : EvidenceResult or None
        Its evidence under the selection's primary likelihood (None without evidence settings).
    intervals : Intervals or None
        50 % and 95 % intervals of its coefficients and modes, the linear part's uncertainty
        included (and its model error, when it is not adequate).
    check : ModelCheck or None
        Its adequacy: residual against the noise it passes on, band by band, quality index,
        validation error (None when its residual could not be computed).
    validation : tuple of SegmentError
        Its closed-loop errors on the selection's held-out segments.
    validation_before : tuple of SegmentError
        Those of the model the loop started from.
    """

    result: NSIResult
    evidence: EvidenceResult | None = None
    intervals: Intervals | None = None
    check: ModelCheck | None = None
    validation: tuple[SegmentError, ...] = ()
    validation_before: tuple[SegmentError, ...] = ()

    @property
    def name(self) -> str:
        """``"final: <term> + <term>"`` (``"final: linear"`` without terms)."""
        return "final: " + (" + ".join(t.name for t in self.result.terms) or "linear")

    @property
    def adequate(self) -> bool | None:
        """Whether its residual is within the noise it passes on (None when not checked)."""
        return None if self.check is None else self.check.adequate


@dataclass(frozen=True)
class Diagnosis:
    """Outcome of :func:`diagnose`.

    Attributes
    ----------
    selection : Selection
        The selection the loop started from.
    start : str
        The candidate the loop started from.
    loop : LoopResult
        The loop: its steps with their scores and decisions, the starting and final models.
    final : FinalModel
        The final model with its evidence, intervals, adequacy and validation errors.
    options : LoopOptions
        The loop's settings.
    findings : tuple of Finding
        What the final model should not be trusted for (e.g. a band where its residual stands out
        of the noise), each also issued as an :class:`~bayesnsi.exceptions.AdequacyWarning`.
    """

    selection: Selection
    start: str
    loop: LoopResult
    final: FinalModel
    options: LoopOptions = field(default_factory=LoopOptions)
    findings: tuple[Finding, ...] = ()

    def __repr__(self) -> str:
        from ._repr import compact_repr

        return compact_repr(
            self, start=self.start, added=tuple(s.term.name for s in self.added),
            rejected=sum(not s.accepted for s in self.loop.steps), adequate=self.final.adequate,
            findings=len(self.findings),
        )

    @property
    def added(self) -> tuple[LoopStep, ...]:
        """The accepted steps, in the order they were added."""
        return self.loop.added

    @property
    def start_result(self) -> NSIResult:
        """The starting model as the loop identified it."""
        return self.loop.start


def diagnose(
    selection: Selection,
    options: LoopOptions | None = None,
    *,
    start: str | None = None,
    execution: ExecutionOptions | None = None,
) -> Diagnosis:
    """Close the loop from a candidate of a selection and check the model it ends with (docs/method.md §7).

    Parameters
    ----------
    selection : Selection
        What :func:`bayesnsi.select` returned (it holds the data, the held-out segments and the
        settings the loop reuses).
    options : LoopOptions, optional
        The loop's settings (default ``LoopOptions()``).
    start : str, optional
        The candidate to start from. Default: the selected one or, when that fails a physical
        check (negative dissipation, quality index), the most probable one that passes every check
        (:attr:`Selection.plausible`).
    execution : ExecutionOptions, optional
        Local worker processes or a Dask scheduler for the effects of each step; never changes a
        number.

    Returns
    -------
    Diagnosis

    Raises
    ------
    ConfigError
        When ``start`` is not a candidate of the selection or could not be identified, when no
        candidate was identified, or an effect name of ``options.effects`` is unknown.

    Examples
    --------
    >>> import warnings
    >>> from bayesnsi import EvidenceOptions, LoopOptions, diagnose, select
    >>> from bayesnsi.exceptions import AdequacyWarning
    >>> from bayesnsi.simulate import undeclared_case
    >>> case = undeclared_case("quadratic-damping", seed=0)
    >>> fast = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", interval="posterior")
    >>> with warnings.catch_warnings():  # the declared model lacks v|v|: it is not adequate, and select says so
    ...     warnings.simplefilter("ignore", AdequacyWarning)
    ...     selection = select(case.signals, [case.declared], case.nsi, fast)
    >>> diagnosis = diagnose(selection, LoopOptions(max_steps=1))
    >>> [step.term.name for step in diagnosis.added]
    ['v1*abs(v1)@1']
    """
    require(selection, Selection, "selection", "get one from bayesnsi.select(signals, candidates, ...)")
    options = LoopOptions() if options is None else options
    require(options, LoopOptions, "options", "build one with LoopOptions(...) or LoopOptions.from_mapping(...)")
    signals = selection.signals
    if signals is None:
        raise ConfigError("the selection holds no data: build it with bayesnsi.select(signals, ...)")
    names = [o.name for o in selection.outcomes]
    if start is not None and start not in names:  # before any work
        raise ConfigError(f"--start {start!r} is not a candidate of the config; choose one of {names}")
    loop_effects(signals, options.effects)  # unknown effect names: ConfigError before any work
    results = selection.results
    if not results:
        raise ConfigError("no candidate could be identified, so there is no model to start the loop from")
    start = start or selection.plausible or selection.selected or next(iter(results))
    if start not in results:
        error = selection.outcome(start).error
        raise ConfigError(
            f"--start {start!r} could not be identified ({error or 'no model'}), so the loop cannot start from it; "
            "change [nsi] block_rows or order until it identifies (bayesnsi identify shows each candidate), "
            f"or start from one of {sorted(results)}"
        )
    loop = close_the_loop(signals, results[start].candidate, options, nsi=selection.nsi, evidence=selection.evidence,
                          execution=execution)
    final = _final_model(loop, selection, start)
    limit = selection.evidence.max_band_ratio if selection.evidence is not None else 2.0
    found = band_findings(final.check, final.name, "the final model", limit) if loop.added else ()
    found += _unexplained(loop)
    emit(found, AdequacyWarning, stacklevel=2)
    return Diagnosis(selection, start, loop, final, options, tuple(found))


def _unexplained(loop: LoopResult) -> tuple[Finding, ...]:
    """A finding when the evidence favours an effect the loop neither added nor rejected (loop and select disagree)."""
    rows = loop.unexplained()
    if not rows:
        return ()
    listed = ", ".join(f"{name} (log Bayes factor {bf:.3g})" for _, name, bf in rows)
    return (Finding(
        "loop.unexplained",
        f"the evidence favours {listed} over the final model by more than the loop's threshold "
        f"({loop.options.threshold:.3g}), but the loop neither added nor examined it (each step examines only the "
        f"n_tries = {loop.options.n_tries} effects best by evidence); rerun with a larger --n-tries",
        "", "warning", {"terms": tuple(name for _, name, _ in rows), "threshold": loop.options.threshold}),)


def _final_model(loop: LoopResult, selection: Selection, start: str) -> FinalModel:
    """The final model's evidence, intervals, adequacy and validation errors (as ``select`` gives a candidate's).

    When the loop added nothing and did not re-identify, the final model is the start, whose evidence,
    intervals and check the selection holds. Otherwise its evidence and intervals are computed with
    the selection's evidence settings (so that its evidence compares with the candidates') and the
    settings it was identified with (:func:`bayesnsi.uncertainty.candidate_intervals`), and its
    intervals are widened by its model error when it is not adequate
    (:func:`bayesnsi.uncertainty.widen_final`).
    """
    segments = selection.segments
    before = validate(loop.start, segments) if segments else ()
    after = validate(loop.final, segments) if segments else ()
    evidence = selection.evidence
    if evidence is None:
        return FinalModel(loop.final, validation=after, validation_before=before)
    if not loop.added and loop.final is loop.start:  # not re-identified: the selection's own figures
        outcome = selection.outcome(start)
        own = None if outcome.evidences is None else outcome.evidences.get(evidence.likelihood)
        return FinalModel(loop.final, own, outcome.intervals, selection.checks.get(start), after, before)
    from .evidence import candidate_evidence
    from .uncertainty import candidate_intervals, widen_final

    options = evidence.replace(compare=())
    seeds = np.random.SeedSequence(options.seed)
    signals = selection.signals
    try:
        result = candidate_evidence(loop.final, signals, options, seeds, warn=False)[options.likelihood]
    except (BayesNSIError, np.linalg.LinAlgError):
        return FinalModel(loop.final, validation=after, validation_before=before)
    intervals = candidate_intervals(loop.final, signals, result, options, loop.final_nsi)
    intervals, check = widen_final(loop.final, intervals, signals, max_noise_ratio=evidence.max_noise_ratio,
                                   max_imag_ratio=evidence.max_imag_ratio, validation=after)
    return FinalModel(loop.final, result, intervals, check, after, before)
