"""Model selection as one library call: identify every candidate, rank them, validate (docs/method.md §6).

:func:`select` runs every candidate through NSI and the evidence (:func:`bayesnsi.run.run_candidates`),
ranks them by the plain Gaussian likelihood of the source paper and by the marginal evidence
side by side (:func:`bayesnsi.evidence.compare_evidence`), picks the most probable model and
simulates every identified model on held-out segments. The command line, the workflows and the
results.json record (:func:`bayesnsi.io.selection_payload`) are built from the
:class:`Selection` it returns.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .exceptions import AdequacyWarning, BayesNSIError
from .nsi.order import order_messages
from .nsi.physics import excluded_lines_messages
from .options import EvidenceOptions, ExecutionOptions, NSIOptions
from .run.adequacy import ModelCheck, adequacy_warnings, model_checks, widen_inadequate
from .run.batch import CandidateOutcome, run_candidates
from .run.force_noise import force_noise_messages
from .run.free_view import one_view
from .run.velocity_noise import velocity_noise_messages
from .validation import (
    SegmentError,
    Whiteness,
    level_messages,
    open_loop_error,
    residual_whiteness,
    validate,
    whiteness_applies,
)

__all__ = ["Selection", "select"]


@dataclass(frozen=True)
class Selection:
    """Outcome of :func:`select`.

    Attributes
    ----------
    outcomes : tuple of CandidateOutcome
        One per candidate, in the order given.
    table : pandas.DataFrame or None
        Ranking table of :func:`bayesnsi.evidence.ranking_table` indexed by candidate name: the
        plain Gaussian log-likelihood and its posterior probability (``p_plain``), and per
        likelihood the log evidence and posterior probability ``p_<likelihood>`` with its
        standard deviation ``p_<likelihood>_sd``. None when no evidence was computed.
    nsi : NSIOptions
        Identification settings used.
    evidence : EvidenceOptions or None
        Evidence settings used (None: identification only).
    validation : mapping of str to tuple of SegmentError
        Closed-loop errors of each identified candidate on each held-out segment.
    adequacy : mapping of str to Whiteness
        Whiteness test of each identified candidate's residual (the evidence's residual) on the
        estimation data (:func:`bayesnsi.validation.residual_whiteness`): the probabilities
        rank the candidates against each other, this says whether the best one explains the data.
        Empty for responses integrated from velocities or accelerations, whose noise the integration
        colours (:func:`bayesnsi.validation.whiteness_applies`; ``checks`` hold their adequacy).
    checks : mapping of str to ModelCheck
        Residual against the noise the model passes on, quality index, validation error and log predictive
        density of each identified candidate (:func:`bayesnsi.run.adequacy.model_checks`).
    warnings : tuple of str
        What the selection should not be trusted for (:func:`bayesnsi.run.adequacy.adequacy_warnings`),
        each also issued as an :class:`~bayesnsi.exceptions.AdequacyWarning`.
    open_loop : mapping of str to MeasuredError
        Open-loop error of each identified candidate on the estimation data in the measured
        quantity (accelerations when accelerations were measured; :func:`bayesnsi.validation.open_loop_error`).
    """

    outcomes: tuple[CandidateOutcome, ...]
    table: Any
    nsi: NSIOptions
    evidence: EvidenceOptions | None
    validation: Mapping[str, tuple[SegmentError, ...]] = field(default_factory=dict)
    adequacy: Mapping[str, Whiteness] = field(default_factory=dict)
    checks: Mapping[str, ModelCheck] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    open_loop: Mapping[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        from ._repr import compact_repr

        return compact_repr(
            self, candidates=tuple(o.name for o in self.outcomes), selected=self.selected, likelihood=self.likelihood,
            failed=tuple(o.name for o in self.outcomes if o.result is None),
        )

    @property
    def likelihood(self) -> str | None:
        """Likelihood whose evidence selects the model (``EvidenceOptions.likelihood``)."""
        return None if self.evidence is None else self.evidence.likelihood

    @property
    def selected(self) -> str | None:
        """Name of the candidate of highest posterior probability under the marginal evidence.

        None without evidence or when no candidate has an evidence.
        """
        return self._best(f"p_{self.likelihood}")

    @property
    def plausible(self) -> str | None:
        """The most probable candidate (as :attr:`selected`) whose model passes every physical check.

        Its quality index is below ``max_imag_ratio`` and none of its friction or damping terms feeds
        energy in (negative dissipation; :class:`~bayesnsi.run.adequacy.ModelCheck`). The evidence can
        favour a model that fails them: on a nearly linear test a sign() of a noisy velocity with a
        negative coefficient won by 4.6e4 nat. A term whose 95 % interval holds zero is not a failed
        check (the data leave its size open, which the warnings say; a model lacking modes widens the
        true term's interval past zero). None when no candidate passes or nothing was checked.
        """
        column = f"log_evidence_{self.likelihood}"
        if self.table is None or column not in self.table or not self.checks:
            return None
        sound = [name for name, c in self.checks.items()
                 if c.quality_ok and not c.energy_input and name in self.table.index
                 and self.outcome(name).evidences is not None and np.isfinite(self.table.loc[name, column])]

        def log_posterior(name):  # not the probability, which is 0 for every candidate far behind the first
            prior = float(self.table.loc[name, "prior"]) if "prior" in self.table else 1.0
            return float(self.table.loc[name, column]) + np.log(max(prior, np.finfo(float).tiny))

        return max(sound, key=log_posterior) if sound else None

    @property
    def selected_gaussian(self) -> str | None:
        """Name of the candidate of highest posterior probability under the plain Gaussian likelihood."""
        return self._best("p_plain")

    @property
    def results(self) -> dict:
        """Identified models by candidate name (failed identifications left out)."""
        return {o.name: o.result for o in self.outcomes if o.result is not None}

    @property
    def evidences(self) -> dict:
        """Evidence results by candidate name, then by likelihood (candidates without one left out)."""
        return {o.name: dict(o.evidences) for o in self.outcomes if o.evidences is not None}

    def outcome(self, name: str) -> CandidateOutcome:
        """The outcome of candidate ``name``.

        Parameters
        ----------
        name : str
            Candidate name.

        Returns
        -------
        CandidateOutcome

        Raises
        ------
        KeyError
            When no candidate has that name.
        """
        for outcome in self.outcomes:
            if outcome.name == name:
                return outcome
        raise KeyError(f"no candidate named {name!r}; candidates: {[o.name for o in self.outcomes]}")

    def _best(self, column: str) -> str | None:
        if self.table is None or column not in self.table:
            return None
        ranked = [o.name for o in self.outcomes if o.status == "ok" and o.evidences is not None]
        if not ranked:
            return None
        return max(ranked, key=lambda name: float(self.table.loc[name, column]))


def select(
    signals,
    candidates: Sequence,
    nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None,
    *,
    execution: ExecutionOptions | None = None,
    validation: Sequence = (),
) -> Selection:
    """Identify every candidate, rank them by Bayesian evidence and check them (docs/method.md §6).

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidates : sequence of CandidateModel
        The database of candidate models (names unique); their ``prior`` gives the prior model
        probabilities.
    nsi : NSIOptions, optional
        Identification settings (default ``NSIOptions()``).
    evidence : EvidenceOptions, optional
        Evidence settings (default ``EvidenceOptions()``); ``seed`` roots every random choice.
    execution : ExecutionOptions, optional
        Backend, cache and progress callback (:func:`bayesnsi.run.run_candidates`); they never
        change a number.
    validation : sequence of (str, Signals)
        Held-out segments on which every identified model is simulated in closed loop
        (:func:`bayesnsi.validation.validate`).

    Returns
    -------
    Selection

    References
    ----------
    R. Zhu, Q. Fei, D. Jiang, S. Marchesiello, D. Anastasio, "Bayesian Model Selection in
    Nonlinear Subspace Identification", AIAA Journal, doi:10.2514/1.J060782: Eqs. 1-4 (the plain
    Gaussian ranking reported beside the marginal evidence).

    Examples
    --------
    >>> from bayesnsi import EvidenceOptions, NSIOptions, simulate_case
    >>> case = simulate_case("two-dof", seed=0, duration=10.0)
    >>> fast = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white")
    >>> selection = select(case.signals, case.candidates, NSIOptions(block_rows=40, order=4), fast)
    >>> selection.selected
    'model 1'
    """
    from .evidence import compare_evidence

    evidence = EvidenceOptions() if evidence is None else evidence
    outcomes = tuple(run_candidates(signals, candidates, nsi, evidence, execution=execution))
    outcomes, view_notes = one_view(signals, outcomes, nsi, evidence, execution)  # free bodies: one view
    rng = np.random.default_rng(np.random.SeedSequence(evidence.seed).spawn(len(outcomes) + 1)[-1])
    table = compare_evidence(
        {o.name: None if o.evidences is None else list(o.evidences.values()) for o in outcomes},
        priors=[o.candidate.prior for o in outcomes],
        rng=rng,
    )
    identified = [o for o in outcomes if o.result is not None]
    segments = list(validation)
    checks = {o.name: validate(o.result, segments) for o in identified} if segments else {}
    adequacy = {}
    for o in identified if whiteness_applies(signals) else ():  # integrated responses: coloured noise, no test
        if o.whiteness is not None:  # tested with its evidence, on the same residual
            adequacy[o.name] = o.whiteness
            continue
        try:
            adequacy[o.name] = residual_whiteness(o.result, signals, evidence.residual)
        except (BayesNSIError, np.linalg.LinAlgError):
            continue  # the outcome already says why this candidate has no evidence
    limits = {"max_noise_ratio": evidence.max_noise_ratio, "max_imag_ratio": evidence.max_imag_ratio}
    fits = model_checks(outcomes, signals, checks, **limits, seed=evidence.seed)
    outcomes, fits = widen_inadequate(outcomes, fits, signals)  # their intervals carry the model error too
    selection = Selection(outcomes, table, nsi or NSIOptions(), evidence, checks, adequacy, fits)
    messages = adequacy_warnings(fits, selection.selected, **limits, max_band_ratio=evidence.max_band_ratio)
    messages += order_messages(outcomes) + excluded_lines_messages(outcomes, selection.selected)
    messages += view_notes + tuple(velocity_noise_messages(signals, candidates, (nsi or NSIOptions()).velocity_method))
    messages += tuple(level_messages(signals, segments)) + tuple(force_noise_messages(signals))
    for message in messages:
        warnings.warn(message, AdequacyWarning, stacklevel=2)
    open_loop = {o.name: e for o in identified if (e := open_loop_error(o.result, signals)) is not None}
    return replace(selection, warnings=messages, open_loop=open_loop)
