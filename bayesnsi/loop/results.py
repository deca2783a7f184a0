"""What the loop returns: a scored effect, a checked step, the loop's outcome (docs/method.md §7)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..models import CandidateModel, Effect, Term
from ..options import EvidenceOptions, LoopOptions, NSIOptions
from .forces import ResidualForce

if TYPE_CHECKING:
    from ..nsi import NSIResult
    from .friction import FrictionReading

__all__ = ["Check", "EffectScore", "LoopResult", "LoopStep", "score_record"]


@dataclass(frozen=True)
class EffectScore:
    """One effect of the dictionary scored against a model.

    Attributes
    ----------
    effect : Effect
    log_evidence : float
        Laplace log-evidence of the model enlarged by the effect: −inf when its identification
        failed, NaN when the frequency-domain screen left it out (not re-identified).
    nrmse : float
        Open-loop NRMSE of the enlarged model, NaN when not computed.
    result : NSIResult or None
        The enlarged model (None in :attr:`LoopResult.scores`, which keep the scores only).
    error : str
        Why the score is −inf (the identification or the evidence failed), else empty.
    screen_rank : int
        Rank (1 = best) of the effect in the search's screen; 0 when the search had no screen.
    screen_score : float
        Its screen score (a log-likelihood ratio of the effect's column in a local regression of the
        outputs, :func:`bayesnsi.loop.screen.screen_effects`, or of the force view); it only
        orders the effects. NaN without a screen.
    screen_view : str
        Which screen ranked it: "frequency" (:func:`bayesnsi.loop.screen.screen_effects`),
        "force" (free body, :func:`bayesnsi.loop.screen_force.screen_effects_force`),
        "periodic" (:func:`bayesnsi.loop.localise.screen_effects_periodic`), or empty.
    screen_location : float
        On the periodic view, the data-only distortion level of the effect's location
        (:func:`bayesnsi.loop.localise.location_distortion`), which orders the screen before
        the score; NaN otherwise.
    log_bayes_factor : float
        ``log_evidence`` minus the Laplace log-evidence of the model the search started from (NaN
        until the search is recorded, :meth:`bayesnsi.loop.state.LoopState.record_scores`).
    imag_ratio : float
        Quality index |Im λ|/|Re λ| of the effect's coefficient in the enlarged model (NaN when
        not identified).
    """

    effect: Effect
    log_evidence: float
    nrmse: float = math.nan
    result: NSIResult | None = field(default=None, repr=False, compare=False)
    error: str = ""
    screen_rank: int = 0
    screen_score: float = math.nan
    screen_view: str = ""
    screen_location: float = math.nan
    log_bayes_factor: float = math.nan
    imag_ratio: float = math.nan

    @property
    def term(self) -> Term:
        """The effect's term."""
        return self.effect.term

    @property
    def screened_out(self) -> bool:
        """True when the screen left the effect out (it was not re-identified)."""
        return math.isnan(self.log_evidence)

    @property
    def identified(self) -> NSIResult:
        """The enlarged model's identification.

        Raises
        ------
        ValueError
            When the score keeps no identification (screened out, failed, or a kept score).
        """
        if self.result is None:
            raise ValueError(f"{self.term.name}: this score keeps no identification ({self.error or 'not kept'})")
        return self.result


@dataclass(frozen=True)
class Check:
    """One check of a proposed effect: the quantity the effect itself shows, its limit, the outcome.

    Every check reads a property of the proposed effect in the model enlarged by it (docs/method.md
    §7, "One acceptance rule"); a rejection names the first check the effect failed, in the order of
    :data:`bayesnsi.loop.guards.CHECK_ORDER`.

    Attributes
    ----------
    name : str
        ``"log Bayes factor"``, ``"quality index"``, ``"record halves"``, ``"separable"``,
        ``"force prediction"`` (free bodies) or ``"dissipation"``.
    value : float
        What the effect shows (the log Bayes factor; its |Im|/|Re|; the ratio of its record-half
        estimates, inf when they differ in sign or one failed; the squared partial correlation with the
        added effect that shares most of its column; the enlarged model's force-prediction NRMSE; its
        coefficient).
    limit : float
        The threshold it is held against (``LoopOptions.threshold``, ``max_imag_ratio``,
        ``stability_factor``, ``max_shared``; the current model's NRMSE; 0).
    passed : bool
    text : str
        The check in words with its value and limit, e.g. ``"quality index |Im|/|Re| = 0.87 >= 0.3"``.
    """

    name: str
    value: float
    limit: float
    passed: bool
    text: str


@dataclass(frozen=True)
class LoopStep:
    """One accepted (or the best rejected) effect.

    Attributes
    ----------
    effect : Effect
        Type, location (its term) and parameters (a clearance's gap, a tanh friction's width).
    accepted : bool
    reason : str
        Why it was accepted or rejected.
    coefficient : float
        NSI estimate of its coefficient.
    ci95 : (float, float)
        95 % highest-density interval of the coefficient's posterior given the identified linear part,
        moved onto ``coefficient`` (:func:`~bayesnsi.loop.guards.about_estimates`); NaN when not
        sampled. The final model's intervals (``final_intervals``) carry the linear part's uncertainty.
    imag_ratio : float
        Quality index |Im λ|/|Re λ|.
    half_coefficients : (float, float)
        Estimates on the first and the second half of the record (NaN when the effect failed
        the Bayes-factor threshold: they are then not computed).
    half_block_rows : int or None
        Block rows the record halves were identified with: ``NSIOptions.block_rows``, or fewer
        when a half is too short for them; None when the halves were not computed.
    half_note : str
        Empty, or why the halves used fewer block rows ("record too short for the halves at 60
        block rows (500 samples each): identified with 41").
    log_bayes_factor : float
        ``log Z(with effect) - log Z(without)``, both by the Laplace approximation.
    nrmse_before, nrmse_after : float
        Open-loop NRMSE of the current and the enlarged model.
    candidate : CandidateModel
        The enlarged candidate.
    closed_loop_nrmse_before, closed_loop_nrmse_after : float
        NRMSE of the closed-loop simulation (docs/method.md §5) on the estimation data of the model without
        and with the effect (for an effect accepted in exchange, "without" is the model holding
        the effect it replaced, as for ``nrmse_before`` and ``log_bayes_factor``); NaN when that
        simulation diverges (chaotic or unstable in feedback, docs/method.md §10) and for rejected effects
        (not computed).
    residual_force : ResidualForce or None
        The residual of the models without and with the effect as a force at its location
        (:func:`bayesnsi.loop.forces.residual_force`); accepted steps only.
    error_quantity : str
        What ``nrmse_before``/``nrmse_after`` measure: "displacement" (open-loop reconstruction),
        or "force" for a free body (the force predicted from the measured motion, IDIM view).
    short_horizon_nrmse_before, short_horizon_nrmse_after : float
        Free bodies, accepted steps: displacement NRMSE of simulations over windows of 1 s
        (:func:`bayesnsi.nsi.short_horizon_nrmse`), which replace the long simulation that drifts.
    search : int or None
        Index in :attr:`LoopResult.scores` of the search that proposed the effect (None for an
        effect proposed in exchange for another, whose search is not recorded).
    checks : tuple of Check
        Every check of the effect with its value and limit (empty for a step recorded before the checks
        were kept, e.g. read from an old results.json).
    quality_only : bool
        True when the quality index is the only check the effect failed: the evidence favours it by
        more than the threshold and its record halves agree (``LoopOptions.accept_quality_only``
        accepts such an effect).
    index_unresolved : bool
        True when the quality index was at or above ``max_imag_ratio`` but passed because the model's
        misfit leaves the frequency dependence of λ(ω) unresolved (:func:`bayesnsi.loop.quality.quality_check`):
        the index could not judge the effect, and the step says so.
    misfit_ratio, memory_resolution : float
        κ and M of :class:`bayesnsi.loop.quality.MisfitReading` (NaN when not read: the index was below
        ``max_imag_ratio`` or the Bayes factor below its threshold).
    """

    effect: Effect
    accepted: bool
    reason: str
    coefficient: float
    ci95: tuple[float, float]
    imag_ratio: float
    half_coefficients: tuple[float, float]
    log_bayes_factor: float
    nrmse_before: float
    nrmse_after: float
    candidate: CandidateModel
    closed_loop_nrmse_before: float = math.nan
    closed_loop_nrmse_after: float = math.nan
    residual_force: ResidualForce | None = None
    error_quantity: str = "displacement"
    short_horizon_nrmse_before: float = math.nan
    short_horizon_nrmse_after: float = math.nan
    half_block_rows: int | None = None
    half_note: str = ""
    search: int | None = None
    checks: tuple[Check, ...] = ()
    quality_only: bool = False
    index_unresolved: bool = False
    misfit_ratio: float = math.nan
    memory_resolution: float = math.nan

    @property
    def failed_checks(self) -> tuple[Check, ...]:
        """The checks the effect failed, in the order they were made."""
        return tuple(c for c in self.checks if not c.passed)

    @property
    def term(self) -> Term:
        """The effect's term (with its location)."""
        return self.effect.term


@dataclass(frozen=True)
class LoopResult:
    """Outcome of :func:`bayesnsi.loop.close_the_loop`.

    Attributes
    ----------
    start, final : NSIResult
        Identified starting and final models. The final model is re-identified on an upsampled
        grid when it holds a term that switches with velocity (``LoopOptions.refine_final``);
        :attr:`final_nsi` holds the settings it was identified with.
    steps : tuple of LoopStep
        Accepted steps in the order they were added, then every rejected (or later removed)
        effect that was checked, in the order checked.
    scores : tuple of tuple of EffectScore
        Per search (one per step, and one per look-ahead), every effect with its Laplace
        log-evidence, best first: −inf when identification failed, NaN (after the scored ones, in
        screen order) when the screen left it out.
    options : LoopOptions
        The loop's settings.
    nsi : NSIOptions
        The identification settings its decisions were made at (a free body's virtual spring fixed).
    final_nsi : NSIOptions
        The settings the final model was identified with.
    evidence : EvidenceOptions
        The evidence settings of its Laplace scores (the loop's residual, the primary likelihood).
    n_effects : int
        Size of the dictionary searched.
    friction : FrictionReading or None
        The physical reading of the final model's friction law (forward and backward viscous
        coefficients, Coulomb level, offset with 95 % intervals; :func:`bayesnsi.loop.friction_reading`)
        on the estimation data, for a one-DOF final model that holds a friction term piecewise linear
        in the velocity (``sign(v)``, ``|v|``, ``v+``); None otherwise. Its offset is the constant force
        beyond the data's mean.
    """

    start: NSIResult
    final: NSIResult
    steps: tuple[LoopStep, ...]
    scores: tuple[tuple[EffectScore, ...], ...]
    options: LoopOptions = field(default_factory=LoopOptions)
    nsi: NSIOptions = field(default_factory=NSIOptions)
    final_nsi: NSIOptions = field(default_factory=NSIOptions)
    evidence: EvidenceOptions = field(default_factory=EvidenceOptions)
    n_effects: int = 0
    friction: FrictionReading | None = None

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(
            self, start=self.start.candidate.name, final_terms=tuple(t.name for t in self.final.terms),
            accepted=tuple(s.term.name for s in self.steps if s.accepted),
            rejected=sum(not s.accepted for s in self.steps),
        )

    @property
    def added(self) -> tuple[LoopStep, ...]:
        """The accepted steps."""
        return tuple(s for s in self.steps if s.accepted)

    def unexplained(self) -> tuple[tuple[int, str, float], ...]:
        """Effects the evidence favours by more than the threshold that the loop neither added nor rejected.

        ``select`` over the loop's own final candidates (the final model enlarged by each effect of
        the searches after the last one that added an effect) prefers such an effect's model by more
        than ``threshold``; the loop must then add the effect or name the check it failed (a step of
        that search). Those effects with a log Bayes factor above ``options.threshold`` and no step
        are listed (e.g. not checked because ``n_tries`` effects failed before them).

        Returns
        -------
        tuple of (int, str, float)
            ``(search index, term name, log Bayes factor)``; empty when the loop and ``select`` agree.
        """
        threshold = self.options.threshold
        added = [s.search for s in self.steps if s.search is not None and (s.accepted or s.reason.startswith(
            ("removed once", "exchanged for")))]  # searches that added an effect (kept or not)
        last = max(added, default=-1)
        out = []
        for index, search in enumerate(self.scores):
            if index <= last:
                continue  # the searches from the model that added its last effect take over
            checked = {s.term.name for s in self.steps if s.search == index}
            out += [(index, row.term.name, float(row.log_bayes_factor)) for row in search
                    if row.log_bayes_factor > threshold and row.term.name not in checked]
        return tuple(out)

    def search_records(self, index: int) -> list[dict]:
        """Every effect of one search with its screen and evidence scores and what became of it.

        Parameters
        ----------
        index : int
            Index of the search in :attr:`scores` (:attr:`LoopStep.search`).

        Returns
        -------
        list of dict
            In the search's order (by Laplace log-evidence, then the screened-out ones in screen
            order): ``type``, ``at``, ``gap``, ``eps``, ``term``, ``screen_rank``, ``screen_score``,
            ``screen_view``, ``screen_location``, ``log_evidence_laplace``, ``log_bayes_factor``, ``nrmse``,
            ``imag_ratio``, ``status`` ("accepted", "rejected", "not checked", "failed",
            "screened out") and ``reason``.
        """
        checked = {s.term.name: s for s in self.steps if s.search == index}
        n_tries, screen = self.options.n_tries, self.options.screen
        return [score_record(row, checked.get(row.term.name), n_tries, screen) for row in self.scores[index]]

    def unexamined(self) -> tuple[EffectScore, ...]:
        """Effects re-identified but never examined that pass the Bayes factor and the quality index.

        The loop examines, per step, only the ``n_tries`` effects best by evidence. When those all
        fail a guard it ends with nothing added although an effect ranked below them may pass the
        Bayes factor and the quality index (a ground vibration test: the joint's cubic, log Bayes
        factor 3.6e4 and |Im|/|Re| 0.20, ranked 4th behind three that failed). "Nothing added"
        must then not read as "nothing passes".

        Returns
        -------
        tuple of EffectScore
            Each such effect once (its first search), in search order.
        """
        examined = {s.term.name for s in self.steps}
        seen: dict[str, EffectScore] = {}
        for search in self.scores:
            for row in search:
                if (row.term.name in examined or row.term.name in seen or row.screened_out
                        or not math.isfinite(row.log_evidence) or not math.isfinite(row.imag_ratio)):
                    continue
                if row.log_bayes_factor > self.options.threshold and row.imag_ratio <= self.options.max_imag_ratio:
                    seen[row.term.name] = row
        return tuple(seen.values())


def score_record(row: EffectScore, step: LoopStep | None = None, n_tries=None, screen=None) -> dict:
    """One scored effect as a plain dict (results.json), with its status and the reason for it.

    Parameters
    ----------
    row : EffectScore
    step : LoopStep, optional
        The step that checked the effect, when one did.
    n_tries, screen : int, optional
        The loop's ``n_tries`` and ``screen`` (for the reasons of effects not checked).

    Returns
    -------
    dict
        As in :meth:`LoopResult.search_records`.
    """
    if step is not None:
        status, reason = ("accepted" if step.accepted else "rejected"), step.reason
    elif row.screened_out:
        status, reason = "screened out", f"screen rank {row.screen_rank} > screen = {screen}: not re-identified"
    elif not math.isfinite(row.log_evidence):
        status, reason = "failed", row.error or "no finite evidence"
    else:
        status, reason = "not checked", f"not among the n_tries = {n_tries} best by evidence"
    effect = row.effect
    return {
        "type": effect.base, "at": list(effect.location), "gap": effect.gap, "eps": effect.eps,
        "shape": None if effect.shape is None else {"beta": effect.shape.beta, "gamma": effect.shape.gamma,
                                                    "n": effect.shape.n},
        "term": row.term.name,
        "screen_rank": row.screen_rank, "screen_score": row.screen_score, "screen_view": row.screen_view,
        "screen_location": row.screen_location, "log_evidence_laplace": row.log_evidence,
        "log_bayes_factor": row.log_bayes_factor, "nrmse": row.nrmse,
        "imag_ratio": row.imag_ratio, "status": status, "reason": reason,
    }
