"""Model selection as one library call: identify every candidate, rank them, validate (docs/method.md §6).

:func:`select` runs every candidate through NSI and the evidence (:func:`bayesnsi.run.run_candidates`),
ranks them by the plain Gaussian likelihood of the source paper and by the marginal evidence
side by side (:func:`bayesnsi.evidence.compare_evidence`), picks the most probable model and
simulates every identified model on held-out segments. The command line, the workflows and the
results.json record (:func:`bayesnsi.io.selection_payload`) are built from the
:class:`Selection` it returns; :func:`bayesnsi.diagnose` closes the loop from it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ._measured import MeasuredError
from .checks.adequacy import ModelCheck, adequacy_findings, model_checks
from .checks.force_noise import force_noise_findings
from .checks.validation import (
    SegmentError,
    Whiteness,
    level_findings,
    open_loop_error,
    residual_whiteness,
    validate,
    whiteness_applies,
)
from .checks.velocity_noise import velocity_noise_findings
from .exceptions import AdequacyWarning, BayesNSIError, require
from .findings import Finding, emit
from .models import CandidateModel
from .nsi.order import order_findings
from .nsi.physics import excluded_lines_findings
from .options import EvidenceOptions, ExecutionOptions, NSIOptions
from .run.batch import CandidateOutcome, run_candidates
from .run.free_view import one_view
from .signals import Signals
from .uncertainty.widening import widen_inadequate

if TYPE_CHECKING:
    import pandas as pd

    from .evidence import EvidenceResult
    from .nsi import NSIResult

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
        estimation data (:func:`bayesnsi.checks.validation.residual_whiteness`): the probabilities
        rank the candidates against each other, this says whether the best one explains the data.
        Empty for responses integrated from velocities or accelerations, whose noise the integration
        colours (:func:`bayesnsi.checks.validation.whiteness_applies`; ``checks`` hold their adequacy).
    checks : mapping of str to ModelCheck
        Residual against the noise the model passes on, quality index, validation error and log predictive
        density of each identified candidate (:func:`bayesnsi.checks.adequacy.model_checks`).
    findings : tuple of Finding
        What the selection should not be trusted for, and what the data hold that it cannot answer
        (:func:`bayesnsi.checks.adequacy.adequacy_findings` and the data checks), each also issued
        as an :class:`~bayesnsi.exceptions.AdequacyWarning` when it is a warning.
    open_loop : mapping of str to MeasuredError
        Open-loop error of each identified candidate on the estimation data in the measured
        quantity (accelerations when accelerations were measured; :func:`bayesnsi.checks.validation.open_loop_error`).
    signals : Signals or None
        The estimation data the selection was made on.
    segments : tuple of (str, Signals)
        The held-out segments the models were validated on.
    """

    outcomes: tuple[CandidateOutcome, ...]
    table: pd.DataFrame | None
    nsi: NSIOptions
    evidence: EvidenceOptions | None
    validation: Mapping[str, tuple[SegmentError, ...]] = field(default_factory=dict)
    adequacy: Mapping[str, Whiteness] = field(default_factory=dict)
    checks: Mapping[str, ModelCheck] = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    open_loop: Mapping[str, MeasuredError] = field(default_factory=dict)
    signals: Signals | None = field(default=None, repr=False, compare=False)
    segments: tuple[tuple[str, Signals], ...] = field(default=(), repr=False, compare=False)

    def __repr__(self) -> str:
        from ._repr import compact_repr

        return compact_repr(
            self, candidates=tuple(o.name for o in self.outcomes), selected=self.selected, likelihood=self.likelihood,
            failed=tuple(o.name for o in self.outcomes if o.result is None), findings=len(self.findings),
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
        energy in (negative dissipation; :class:`~bayesnsi.checks.adequacy.ModelCheck`). The evidence can
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
    def results(self) -> dict[str, NSIResult]:
        """Identified models by candidate name (failed identifications left out)."""
        return {o.name: o.result for o in self.outcomes if o.result is not None}

    @property
    def evidences(self) -> dict[str, dict[str, EvidenceResult]]:
        """Evidence results by candidate name, then by likelihood (candidates without one left out)."""
        return {o.name: dict(o.evidences) for o in self.outcomes if o.evidences is not None}

    def comparison(self) -> pd.DataFrame:
        """The candidates side by side, most probable first, like :func:`arviz_stats.compare`.

        Returns
        -------
        pandas.DataFrame
            Index ``candidate``; columns ``rank`` (by the marginal evidence), ``log_evidence`` and
            ``log_evidence_se`` (its Monte-Carlo error) under :attr:`likelihood`, ``delta_log_evidence``
            (against the best), ``probability`` and ``probability_sd`` (posterior model probability and
            its Monte-Carlo sd), ``plain_rank`` and ``p_plain`` (the paper's plain Gaussian ranking),
            ``noise_ratio`` (residual over the noise it passes on), ``adequate`` and ``status``.
            Candidates without evidence come last with NaN.

        Raises
        ------
        BayesNSIError
            When no evidence was computed (``evidence=None``).
        """
        import pandas as pd

        if self.table is None or self.likelihood is None:
            raise BayesNSIError("no evidence was computed: select(..., evidence=EvidenceOptions()) compares candidates")
        lik, table = self.likelihood, self.table
        log_z = table[f"log_evidence_{lik}"].to_numpy(dtype=float)
        best = np.nanmax(np.where(np.isfinite(log_z), log_z, np.nan)) if np.any(np.isfinite(log_z)) else math.nan
        frame = pd.DataFrame({
            "log_evidence": log_z,
            "log_evidence_se": table[f"log_evidence_se_{lik}"].to_numpy(dtype=float),
            "delta_log_evidence": log_z - best,
            "probability": table[f"p_{lik}"].to_numpy(dtype=float),
            "probability_sd": table[f"p_{lik}_sd"].to_numpy(dtype=float),
            "p_plain": table["p_plain"].to_numpy(dtype=float) if "p_plain" in table else math.nan,
            "plain_log_likelihood": (table["log_likelihood_plain"].to_numpy(dtype=float)
                                     if "log_likelihood_plain" in table else math.nan),
            "noise_ratio": [self.checks[n].noise_ratio if n in self.checks else math.nan for n in table.index],
            "adequate": [self.checks[n].adequate if n in self.checks else None for n in table.index],
            "status": [self.outcome(n).status for n in table.index],
        }, index=pd.Index(table.index, name="candidate"))
        frame.insert(0, "rank", frame["log_evidence"].rank(ascending=False, method="min", na_option="bottom"))
        frame.insert(7, "plain_rank", frame["plain_log_likelihood"].rank(ascending=False, method="min",
                                                                        na_option="bottom"))
        frame = frame.drop(columns="plain_log_likelihood")
        return frame.sort_values(["rank", "probability"], ascending=[True, False])

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
        table = self.table
        if table is None or column not in table:
            return None
        ranked = [o.name for o in self.outcomes if o.status == "ok" and o.evidences is not None]
        if not ranked:
            return None
        return max(ranked, key=lambda name: float(table.loc[name, column]))


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
        (:func:`bayesnsi.checks.validation.validate`).

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

    require(signals, Signals, "signals", "build one with bayesnsi.Signals(force=..., displacement=..., fs=..., ...)")
    evidence = EvidenceOptions() if evidence is None else evidence
    nsi = NSIOptions() if nsi is None else nsi
    require(nsi, NSIOptions, "nsi", "build one with NSIOptions(...) or NSIOptions.from_mapping(...)")
    require(evidence, EvidenceOptions, "evidence", "build one with EvidenceOptions(...)")
    if execution is not None:
        require(execution, ExecutionOptions, "execution", "build one with ExecutionOptions(jobs=..., ...)")
    candidates = tuple(candidates)
    for k, candidate in enumerate(candidates):
        require(candidate, CandidateModel, f"candidates[{k}]", "build one with bayesnsi.CandidateModel(name, terms)")
    outcomes = tuple(run_candidates(signals, candidates, nsi, evidence, execution=execution))
    outcomes, view = one_view(signals, outcomes, nsi, evidence, execution)  # free bodies: one view
    rng = np.random.default_rng(np.random.SeedSequence(evidence.seed).spawn(len(outcomes) + 1)[-1])
    table = compare_evidence(
        {o.name: None if o.evidences is None else list(o.evidences.values()) for o in outcomes},
        priors=[o.candidate.prior for o in outcomes],
        rng=rng,
    )
    identified = [o for o in outcomes if o.result is not None]
    segments = tuple((str(name), record) for name, record in validation)
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
    limits = {"max_noise_ratio": evidence.max_noise_ratio, "max_imag_ratio": evidence.max_imag_ratio,
              "max_band_ratio": evidence.max_band_ratio}
    fits = model_checks(outcomes, signals, checks, **limits, seed=evidence.seed)
    outcomes, fits = widen_inadequate(outcomes, fits, signals)  # their intervals carry the model error too
    selection = Selection(outcomes, table, nsi, evidence, checks, adequacy, fits, signals=signals, segments=segments)
    found = adequacy_findings(fits, selection.selected, **limits)
    found += order_findings(outcomes) + excluded_lines_findings(outcomes, selection.selected) + tuple(view)
    found += tuple(velocity_noise_findings(signals, candidates, nsi.velocity_method))
    found += tuple(level_findings(signals, segments)) + tuple(force_noise_findings(signals))
    emit(found, AdequacyWarning, stacklevel=2)
    open_loop = {o.name: e for o in identified if (e := open_loop_error(o.result, signals)) is not None}
    return replace(selection, findings=found, open_loop=open_loop)
