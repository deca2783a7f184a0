"""Model adequacy beside the evidence: does the selected model explain the data?

The posterior probabilities compare the candidates with each other; they say nothing when every
candidate is wrong, and the evidence of one candidate can win while it predicts worse. For every
identified candidate :func:`model_checks` reports

* the open-loop reconstruction residual against the noise the model passes on, per output channel
  (ratio ≈ 1 for a model that explains the data): the change of its own residual when fresh sensor
  noise is added to the data (:func:`bayesnsi.checks.residual_bands.propagated_noise`), the noise
  itself plus what the model makes of it through the nonlinear inputs it computes from the noisy
  measurements. Against the sensor noise alone the true clearance and Coulomb models of the
  undeclared cases read 1.09-1.20 and 1.49-2.23 and were called inadequate; against this yardstick
  0.84-0.91 and 0.85-1.63 (docs/calibration.md, "Adequacy ratios"). The sensor noise and its draws:
  :func:`bayesnsi.noise.noise_model`; band by band: :mod:`bayesnsi.checks.residual_bands`;
* the quality index, the largest |Im λ|/|Re λ| of its coefficients (small is good);
* with ``[[validation]]`` segments, the mean closed-loop NRMSE over them and the mean log
  predictive density per sample of the validation data under the plug-in Gaussian predictive
  ``N(ŷ, σ̂_c²)``, ``σ̂_c`` the estimation residual rms of channel c (parameter uncertainty
  left out).

:func:`adequacy_findings` turns them into findings (issued as :class:`~bayesnsi.exceptions.AdequacyWarning`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..exceptions import BayesNSIError
from ..findings import Finding
from ..noise import IntegratedSensorNoise, noise_model, spectral_lines
from .dissipation import injects_energy
from .misfit import index_judgement, misfit_reading
from .residual_bands import MAX_BAND_RATIO, band_findings, propagated_noise, residual_bands

__all__ = ["ModelCheck", "model_checks", "adequacy_findings", "unsupported_terms", "VALIDATION_TOLERANCE"]

EDGE_LIMIT = 2.0
"""Residual rms at the ends of an integrated record over the interior's above which ``adequacy_findings`` says so."""

VALIDATION_TOLERANCE = 0.1
"""The selected model "validates worse" when its validation NRMSE exceeds the best candidate's by more than this
(closed-loop simulation; a free body's force prediction, which does not drift, is compared without tolerance)."""


@dataclass(frozen=True)
class ModelCheck:
    """Adequacy figures of one identified candidate.

    Attributes
    ----------
    name : str
        Candidate name.
    order : int
        Order of its underlying linear model.
    residual_rms, noise_std : tuple of float
        Open-loop reconstruction residual rms and estimated sensor noise std per output channel.
    noise_ratio : float
        Largest ``residual_rms / passed_on_std`` over the channels (``residual_rms / noise_std`` where
        ``passed_on_std`` is empty).
    adequate : bool
        ``noise_ratio <= max_noise_ratio``: the residual is near the noise level.
    quality_index : float or None
        Largest |Im λ|/|Re λ| of its coefficients; None for a linear candidate.
    quality_ok : bool
        Every coefficient passes its quality index: below ``max_imag_ratio``, or, where the model misfits
        its data beyond ``max_noise_ratio``, not resolved against that misfit (the loop's rule,
        :func:`bayesnsi.checks.misfit.index_judgement`; True for a linear candidate).
    unresolved : tuple of str
        The terms whose index passes only as not resolved against the misfit: the index cannot judge them.
    validation_nrmse : float or None
        Mean closed-loop NRMSE over the validation segments (inf when a simulation failed; None
        without validation data).
    validation_log_predictive : float or None
        Mean log predictive density per sample of the validation data [nat] (module notes).
    quantity : str
        What ``residual_rms`` and ``noise_std`` measure: "displacement", or "force" for a free body
        (the force predicted from the measured motion against the measured force, and the force's
        white noise, both through the low-pass filter of :func:`bayesnsi.nsi.force_prediction`).
    unsupported : tuple of (str, float, float)
        Coefficients whose 95 % interval (:attr:`CandidateOutcome.intervals`, the honest segments
        interval when select computed it) includes zero: name, lower and upper bound.
    energy_input : tuple of (str, float)
        Terms that feed energy in: a pure velocity term odd and dissipative in shape (v|v|, v³,
        sign(v), tanh(v/ε)) with a negative coefficient, whose force does positive work on every
        motion (:func:`bayesnsi.loop.guards.injects_energy`, the loop's "negative dissipation"
        guard): name and coefficient.
    widening : float
        Factor its intervals were widened by for its model error (:func:`widen_inadequate`; 1: not).
    noise_source : str
        Where ``noise_std`` comes from: "period scatter", "differences", "accelerometers (estimated)" or
        "accelerometers (declared)" (their white noise integrated by the loader's recipe; "velocity
        sensors (...)" alike), or "force".
    acceleration_noise_std : tuple of float
        With "accelerometers": the accelerometers' white noise std per channel (acceleration unit).
    edge_ratio : float or None
        Accelerations integrated without whole periods and kept to the window's ends: the residual rms
        over the two edges (:meth:`~bayesnsi.noise.AccelerationNoise.interior`) over that
        of the interior, largest channel; None otherwise. Well above 1 it is the integration's edge error,
        which enters the identification and that no replicate carries (``trim_edges``).
    band_ratio, band_hz, band_dof : float, (float, float), int; or None
        The largest ratio of the residual to the noise the model passes on over frequency bands and output
        channels, its band [Hz] and the DOF of its output (:func:`bayesnsi.checks.residual_bands.residual_bands`);
        None for a force residual or a record too short for one band.
    passed_on_std : tuple of float
        The yardstick of ``noise_ratio`` per channel: the rms change of the model's open-loop residual when
        fresh sensor noise is added to the data (:func:`bayesnsi.checks.residual_bands.propagated_noise`), the
        sensor noise as the model passes it on through the nonlinear inputs it computes from the noisy
        measurements; empty for a force residual, a stabilised free body, or when no draw could be
        reconstructed.
    band_edges_hz, band_ratios : tuple of float, tuple of tuple of float
        All bands: their edges [Hz] and, per band, the ratio of each output channel (empty as above).
    """

    name: str
    order: int
    residual_rms: tuple[float, ...]
    noise_std: tuple[float, ...]
    noise_ratio: float
    adequate: bool
    quality_index: float | None
    quality_ok: bool
    validation_nrmse: float | None = None
    validation_log_predictive: float | None = None
    quantity: str = "displacement"
    unsupported: tuple[tuple[str, float, float], ...] = ()
    energy_input: tuple[tuple[str, float], ...] = ()
    widening: float = 1.0
    noise_source: str = "differences"
    acceleration_noise_std: tuple[float, ...] = ()
    edge_ratio: float | None = None
    band_ratio: float | None = None
    band_hz: tuple[float, float] | None = None
    band_dof: int | None = None
    band_edges_hz: tuple[float, ...] = ()
    band_ratios: tuple[tuple[float, ...], ...] = ()
    passed_on_std: tuple[float, ...] = ()
    unresolved: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """JSON-ready record.

        Returns
        -------
        dict
            The fields.
        """
        return {
            "order": self.order, "residual_rms": list(self.residual_rms), "noise_std": list(self.noise_std),
            "noise_ratio": self.noise_ratio, "adequate": self.adequate, "quality_index": self.quality_index,
            "quality_ok": self.quality_ok, "validation_nrmse": self.validation_nrmse,
            "validation_log_predictive": self.validation_log_predictive, "quantity": self.quantity,
            "negative_dissipation": [{"term": name, "coefficient": value} for name, value in self.energy_input],
            "interval_widening": self.widening, "noise_source": self.noise_source,
            "acceleration_noise_std": list(self.acceleration_noise_std), "edge_ratio": self.edge_ratio,
            "band_ratio": self.band_ratio, "band_hz": None if self.band_hz is None else list(self.band_hz),
            "band_dof": self.band_dof, "band_edges_hz": list(self.band_edges_hz),
            "band_ratios": [list(row) for row in self.band_ratios], "passed_on_std": list(self.passed_on_std),
            "quality_unresolved": list(self.unresolved),
        }


def _log_predictive(segments, sigma: np.ndarray) -> float | None:
    """Mean over segments of ``Σ_c [-½ log 2πσ_c² - ½ rmse_c²/σ_c²]`` (nat per sample)."""
    values = []
    for seg in segments:
        if seg.error is not None or not seg.rmse_per_channel:
            return -math.inf
        rmse = np.asarray(getattr(seg, "displacement_rmse_per_channel", ()) or seg.rmse_per_channel, dtype=float)
        values.append(float(np.sum(-0.5 * np.log(2 * np.pi * sigma**2) - 0.5 * rmse**2 / sigma**2)))
    return float(np.mean(values)) if values else None


def model_checks(
    outcomes: Sequence, signals, validation: Mapping | None = None, *, max_noise_ratio: float = 1.3,
    max_imag_ratio: float = 0.3, max_band_ratio: float = MAX_BAND_RATIO, seed: int = 0,
) -> dict[str, ModelCheck]:
    """Adequacy figures of every identified candidate (module notes).

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
        What :func:`bayesnsi.run.run_candidates` gave; candidates without a model are left out.
    signals : Signals
        The estimation data.
    validation : mapping of str to tuple of SegmentError, optional
        Closed-loop errors of each candidate on the validation segments.
    max_noise_ratio : float
        Largest residual-to-noise ratio of an adequate model.
    max_imag_ratio : float
        Largest quality index |Im λ|/|Re λ| accepted.
    max_band_ratio : float
        Misfit ratio above which the quality index is judged against the misfit (``index_judgement``).
    seed : int
        Seed of the noise draws of the yardstick and the band check
        (:func:`bayesnsi.checks.residual_bands.propagated_noise`).

    Returns
    -------
    dict of str to ModelCheck
    """
    from ..nsi import force_noise_std, force_prediction, is_free_body

    validation = validation or {}
    sensors = noise_model(signals)
    noise, source = sensors.std(interior=True), sensors.source
    accelerometers = sensors.recipe if isinstance(sensors, IntegratedSensorNoise) else None
    noise = np.where(noise > 0, noise, np.finfo(float).tiny)
    lines = spectral_lines(signals)
    checks = {}
    for outcome in outcomes:
        result = outcome.result
        if result is None:
            continue
        quantity, level, edges, band, passed_on = "displacement", noise, None, None, None
        try:
            if is_free_body(result):
                # a free body's displacement residual is the drift of its rigid-body mode: judge the
                # force it predicts from the measured motion against the force's noise
                fp = force_prediction(result, signals)
                quantity, rms = "force", np.array([fp.rmse])
                level = np.array([max(force_noise_std(signals, fp.cutoff_hz), np.finfo(float).tiny)])
            else:
                residual = np.asarray(result.reconstruct(signals).residual, dtype=float)
                frequency_route = getattr(result, "settings", {}).get("domain") == "frequency"
                fitted = lines.within(result.band_hz) if frequency_route else lines
                # a stabilised free body rings at its virtual mode: no yardstick, the sensor noise as before
                free = getattr(result, "virtual_stiffness", 0.0)
                changes = [] if free else propagated_noise(result, signals, residual, seed=seed)
                band = residual_bands(residual, changes, fitted)
                if accelerometers is not None:  # integrated: the edges hold the integration's error, not the model's
                    edges = accelerometers.edge_ratio(residual)
                    inner = accelerometers.interior(len(residual))
                    residual, changes = residual[inner], [change[inner] for change in changes]
                rms = np.sqrt(np.mean(residual**2, axis=0))
                if changes:  # the yardstick: the sensor noise as the model passes it on (run.residual_bands)
                    passed_on = np.sqrt(np.mean([np.mean(change**2, axis=0) for change in changes], axis=0))
                    level = np.where(passed_on > 0, passed_on, np.finfo(float).tiny)
        except (BayesNSIError, np.linalg.LinAlgError):
            continue
        ratio = float(np.max(rms / level))
        quality = max((c.imag_ratio for c in result.coefficients), default=None)
        quality_ok, unresolved = _quality(result, signals, max_imag_ratio, max_band_ratio, seed)
        segments = validation.get(outcome.name, ())
        nrmse = None
        if segments:
            nrmse = float(np.mean([s.nrmse if s.nrmse is not None else math.inf for s in segments]))
        checks[outcome.name] = ModelCheck(
            name=outcome.name, order=int(result.order), residual_rms=tuple(float(v) for v in rms),
            noise_std=tuple(float(v) for v in (noise if passed_on is not None else level)), noise_ratio=ratio,
            passed_on_std=() if passed_on is None else tuple(float(v) for v in passed_on),
            adequate=ratio <= max_noise_ratio,
            quality_index=None if quality is None else float(quality),
            quality_ok=quality_ok, unresolved=unresolved, validation_nrmse=nrmse,
            validation_log_predictive=_log_predictive(segments, np.where(rms > 0, rms, level)) if segments else None,
            quantity=quantity, unsupported=unsupported_terms(getattr(outcome, "intervals", None)),
            noise_source="force" if quantity == "force" else source,
            acceleration_noise_std=() if accelerometers is None else accelerometers.acceleration_std,
            edge_ratio=edges,
            energy_input=_energy_input(result),
            **({} if band is None else _worst_band(band, signals.output_dofs)),
        )
    return checks


def _quality(result, signals, max_imag_ratio: float, misfit_bound: float, seed: int) -> tuple[bool, tuple[str, ...]]:
    """Whether every coefficient passes its quality index judged against the model's misfit
    (:func:`bayesnsi.checks.misfit.index_judgement`, the loop's rule), and the terms that pass only as not
    resolved against it."""
    ok, unresolved = True, []
    for k, c in enumerate(result.coefficients):
        if c.imag_ratio < max_imag_ratio:
            continue
        reading = misfit_reading(result, signals, index=k, seed=seed)
        passed, only_unresolved = index_judgement(c.imag_ratio, max_imag_ratio, misfit_bound, reading)
        ok &= passed
        if only_unresolved:
            unresolved.append(c.term.name)
    return ok, tuple(unresolved)


def _worst_band(bands, output_dofs) -> dict:
    """``ModelCheck`` fields of the worst band of ``bands``."""
    ratio, edges, channel = bands.worst()
    return {"band_ratio": ratio, "band_hz": edges, "band_dof": int(output_dofs[channel]),
            "band_edges_hz": tuple(float(e) for e in bands.edges_hz),
            "band_ratios": tuple(tuple(float(r) for r in row) for row in bands.ratios)}


def _interval_clause(check: ModelCheck, subject: str) -> str:
    """What the selected inadequate model's intervals carry (:func:`widen_inadequate`)."""
    if check.widening <= 1.0:
        return f"; {subject} carry the sensor noise only, not its model error"
    return f"; {subject} are widened {check.noise_ratio:.2f}x for its model error"


def unsupported_terms(intervals) -> tuple[tuple[str, float, float], ...]:
    """The coefficients of ``intervals`` whose 95 % interval includes zero.

    Parameters
    ----------
    intervals : Intervals or None

    Returns
    -------
    tuple of (str, float, float)
        Name, lower and upper 95 % bound of each such coefficient.
    """
    coefficients = getattr(intervals, "coefficients", None) or ()
    return tuple((p.name, float(p.ci95[0]), float(p.ci95[1])) for p in coefficients if p.ci95[0] <= 0.0 <= p.ci95[1])


def _energy_input(result) -> tuple[tuple[str, float], ...]:
    """The terms of ``result`` whose identified coefficient feeds energy in (negative dissipation)."""
    return tuple((c.term.name, float(c.value)) for c in result.coefficients if injects_energy(c.term, c.value))


def adequacy_findings(
    checks: Mapping[str, ModelCheck], selected: str | None, *, max_noise_ratio: float = 1.3,
    max_imag_ratio: float = 0.3, max_band_ratio: float = MAX_BAND_RATIO,
) -> tuple[Finding, ...]:
    """What the selection should not be trusted for (empty when nothing is wrong).

    Parameters
    ----------
    checks : mapping of str to ModelCheck
        From :func:`model_checks`.
    selected : str or None
        The selected candidate.
    max_noise_ratio, max_imag_ratio : float
        The thresholds the checks used (quoted in the messages).
    max_band_ratio : float
        Largest band ratio of the selected model before a finding says where it misses the data.

    Returns
    -------
    tuple of Finding
        One finding per failed check (kinds ``adequacy.quality_index``, ``adequacy.quality_unresolved`` (an index
        the model's misfit leaves unresolved), ``adequacy.negative_dissipation``,
        ``adequacy.unsupported_term``, ``adequacy.validation``, ``adequacy.none_adequate``,
        ``adequacy.not_adequate``, ``adequacy.edges``, ``adequacy.band``, ``adequacy.orders``): the
        selected model fails the quality index; it holds a dissipative-shaped velocity term with a
        negative coefficient (negative dissipation); it validates more than
        :data:`VALIDATION_TOLERANCE` worse than another candidate (a free body's force prediction:
        worse at all); it holds a term whose 95 % interval includes zero; its residual is not near
        the noise level while another candidate's is; no candidate's residual is near the noise
        level; the candidates have linear parts of different orders. When the selected model's
        residual is not near the noise, the message says whether its intervals were widened by that
        ratio (:func:`bayesnsi.uncertainty.widen_inadequate`).
    """
    out: list[Finding] = []
    subject = selected or ""
    chosen = checks.get(selected) if selected is not None else None
    if chosen is not None and chosen.unresolved:
        out.append(Finding(
            "adequacy.quality_unresolved",
            f"the selected model {selected!r} holds {', '.join(chosen.unresolved)} whose quality index exceeds "
            f"{max_imag_ratio:g} but is not resolved against the model's misfit (its residual is "
            f"{chosen.noise_ratio:.3g}x the noise): the index cannot judge it (docs/method.md §7)",
            subject, values={"terms": tuple(chosen.unresolved), "limit": max_imag_ratio}))
    if chosen is not None and not chosen.quality_ok:
        out.append(Finding(
            "adequacy.quality_index",
            f"the selected model {selected!r} fails the quality index: |Im|/|Re| = {chosen.quality_index:.3g} > "
            f"{max_imag_ratio:g} (its coefficients are not constant over the band)",
            subject, values={"quality_index": chosen.quality_index, "limit": max_imag_ratio}))
    for name, value in chosen.energy_input if chosen is not None else ():
        out.append(Finding(
            "adequacy.negative_dissipation",
            f"the selected model {selected!r} holds {name} = {value:.4g}: a friction or damping term with a negative "
            "coefficient feeds energy in on every motion (negative dissipation, docs/method.md §7); it compensates "
            "something the candidates lack (e.g. too much linear damping), it is not a physical friction or damping",
            subject, values={"term": name, "coefficient": value}))
    for name, low, high in chosen.unsupported if chosen is not None else ():
        out.append(Finding(
            "adequacy.unsupported_term",
            f"term {name} is not supported by the data: its 95 % interval [{low:.4g}, {high:.4g}] includes 0",
            subject, values={"term": name, "ci95_low": low, "ci95_high": high}))
    out.extend(_validation_findings(checks, selected, chosen))
    if checks and not any(c.adequate for c in checks.values()):
        best = min(checks, key=lambda n: checks[n].noise_ratio)
        what = " (force residual against the force noise)" if checks[best].quantity == "force" else ""
        out.append(Finding(
            "adequacy.none_adequate",
            f"no candidate is adequate: every residual is more than {max_noise_ratio:g}x the noise it passes on "
            f"(best {best!r}: {checks[best].noise_ratio:.2f}x{what}); the probabilities only rank wrong models"
            + (_interval_clause(chosen, "the selected model's intervals") if chosen is not None else ""),
            subject, values={"best": best, "best_noise_ratio": checks[best].noise_ratio, "limit": max_noise_ratio,
                             "widening": None if chosen is None else chosen.widening}))
    elif chosen is not None and not chosen.adequate:
        out.append(Finding(
            "adequacy.not_adequate",
            f"the selected model {selected!r} is not adequate: its residual is {chosen.noise_ratio:.2f}x the noise it "
            f"passes on (more than {max_noise_ratio:g}x) while another candidate's is within it"
            + _interval_clause(chosen, "its intervals"),
            subject, values={"noise_ratio": chosen.noise_ratio, "limit": max_noise_ratio,
                             "widening": chosen.widening}))
    if chosen is not None and chosen.edge_ratio is not None and chosen.edge_ratio > EDGE_LIMIT:
        out.append(Finding(
            "adequacy.edges",
            f"the selected model's residual is {chosen.edge_ratio:.1f}x larger at the ends of the record than inside "
            "it: the integrated accelerations miss the motion outside the window there (edge error of the "
            "integration), which biases the estimates and the evidence and which the intervals do not carry; set "
            "[data] integrate = { ..., trim_edges = true } (docs/method.md §11)",
            subject, values={"edge_ratio": chosen.edge_ratio, "limit": EDGE_LIMIT}))
    out.extend(band_findings(chosen, selected, limit=max_band_ratio))
    orders = sorted({c.order for c in checks.values()})
    if len(orders) > 1:
        detail = ", ".join(f"{n}: {c.order}" for n, c in checks.items())
        out.append(Finding(
            "adequacy.orders",
            f"the candidates were compared on linear parts of different orders ({detail}); set [nsi] order to "
            "one value to compare the nonlinear parts alone",
            "", values={"orders": tuple(orders)}))
    return tuple(out)


def _validation_findings(checks: Mapping[str, ModelCheck], selected: str | None,
                         chosen: ModelCheck | None) -> list[Finding]:
    """The selected model against the best-validating other candidate (:func:`adequacy_findings`)."""
    if chosen is None or chosen.validation_nrmse is None:
        return []
    others = {n: c.validation_nrmse for n, c in checks.items() if n != selected and c.validation_nrmse is not None}
    if not others:
        return []
    best = min(others, key=lambda n: others[n])
    # a free body's force prediction does not drift as a long simulation does: any reversal counts
    force = chosen.quantity == "force"
    if not chosen.validation_nrmse > (1 + (0.0 if force else VALIDATION_TOLERANCE)) * others[best]:
        return []
    what = "force-prediction NRMSE (free body)" if force else "closed-loop NRMSE"
    values: dict[str, float | str | None] = {"validation_nrmse": chosen.validation_nrmse, "best": best,
                                             "best_validation_nrmse": others[best]}
    if not math.isfinite(chosen.validation_nrmse):  # its simulation failed: no error to compare
        message = (
            f"the selected model {selected!r} could not be validated - its "
            f"{'force prediction' if force else 'closed-loop simulation'} failed on the validation data "
            f"(the error is in results.json validation) - while {best!r} validates with {what} {others[best]:.3g}"
        )
    else:
        worse = 100 * (chosen.validation_nrmse / others[best] - 1)
        message = (
            f"the selected model {selected!r} validates worse than {best!r}: {what} "
            f"{chosen.validation_nrmse:.3g} against {others[best]:.3g} (+{worse:.2g} %) on the validation data"
        )
    return [Finding("adequacy.validation", message, selected or "", "warning", values)]
