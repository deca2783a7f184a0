"""Intervals that carry the uncertainty of the identified linear part (docs/method.md §11).

The coefficient posterior of :func:`~bayesnsi.evidence.marginal_evidence` conditions on the
identified underlying linear model (A, C and, with them, B, D) as if it were exact; on the
two-DOF case its sd of α is about 10× smaller than the seed-to-seed scatter of the estimate.
:func:`candidate_intervals` widens it with the scatter of the whole identification over replicates
of the record (:data:`INTERVAL_METHODS`):

* ``"noise"`` and ``"surrogate"`` (the default ``"auto"`` picks one per candidate): the scatter and
  the errors-in-variables bias over copies of the record with added sensor noise
  (:mod:`.replicates`) or over records of the identified model driven by phase-randomised
  forces (:mod:`.surrogate`), with Student-t quantiles; the intervals are centred on
  ``estimate - bias``, the 95 % one stretched to hold the reported estimate.
* ``"segments"`` (:mod:`.windows`): ``n_segments`` windows of ``b = segment_fraction · N`` samples are
  re-identified with the full record's order and band; for an error variance ``σ²/b`` the
  full-record variance is ``b/(N - b) · mean_w (θ_w - θ_N)²`` (delete-d jackknife), added to the
  posterior's, normal quantiles about the NSI value (the windows overlap, so the variance carries
  about 2.7 degrees of freedom and under-covers); modes are matched to the nearest window mode.

The posterior-only intervals are the posterior's quantiles shifted by ``NSI value - posterior mean``.
A note says when the posterior mean falls outside the 95 % interval (the evidence's estimator and
NSI then disagree by more than their scatter, as on a free body). Measured coverage and widths are
in ``benchmarks/calibration_intervals.py`` and docs/calibration.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import IntervalWarning
from ..findings import Finding, emit
from .windows import scatter_sd, segment_estimates

__all__ = ["INTERVAL_METHODS", "ParameterInterval", "Intervals", "candidate_intervals"]

INTERVAL_METHODS = ("posterior", "segments", "noise", "surrogate")
"""``"posterior"``: the coefficient posterior alone (conditional on the linear part);
``"segments"``: widened by the sub-record scatter of the identification (module notes);
``"noise"``: the scatter and errors-in-variables bias of the identification over copies
of the record with added sensor noise (:mod:`bayesnsi.uncertainty.replicates`); ``"surrogate"``:
the same over records of the identified model driven by phase-randomised copies of the force
(:mod:`bayesnsi.uncertainty.surrogate`). The option's default ``"auto"`` is ``"surrogate"`` for a
candidate with a Coulomb friction term (a sign() of velocities alone) where the record allows it,
else ``"noise"``."""

_Z95 = 1.959963984540054
_Z50 = 0.6744897501960817


@dataclass(frozen=True)
class ParameterInterval:
    """Estimate, standard deviation and 50 % / 95 % intervals of one parameter.

    Attributes
    ----------
    name : str
        Coefficient name, ``f<k>`` (natural frequency of mode k [Hz]) or ``zeta<k>`` (damping ratio).
    estimate : float
        The reported estimate the intervals are centred on: the full-record NSI coefficient
        (coefficients) or the full-record mode (modes).
    sd : float
        Total standard deviation.
    posterior_sd : float
        Posterior standard deviation given the linear part (NaN for modal parameters).
    segment_sd : float
        Standard deviation from the sub-record scatter, or of the noise replicates (``method = "noise"``;
        NaN with ``method = "posterior"``).
    ci50, ci95 : tuple of float
        Central 50 % and 95 % intervals.
    posterior_mean : float
        Mean of the coefficient posterior (NaN for modal parameters).
    bias : float
        Errors-in-variables bias of ``estimate`` estimated from the noise replicates (NaN with other
        methods): the intervals are centred on ``estimate - bias``, the 95 % one stretched to hold
        ``estimate``.
    """

    name: str
    estimate: float
    sd: float
    posterior_sd: float
    segment_sd: float
    ci50: tuple[float, float]
    ci95: tuple[float, float]
    posterior_mean: float = math.nan
    bias: float = math.nan

    def to_dict(self) -> dict:
        """JSON-ready record.

        Returns
        -------
        dict
            The fields, intervals as two-element lists.
        """
        return {
            "name": self.name, "estimate": self.estimate, "sd": self.sd, "posterior_sd": self.posterior_sd,
            "segment_sd": self.segment_sd, "ci50": list(self.ci50), "ci95": list(self.ci95),
            "posterior_mean": self.posterior_mean, "bias": self.bias,
        }


@dataclass(frozen=True)
class Intervals:
    """Intervals of a candidate's coefficients and modal parameters.

    Attributes
    ----------
    method : str
        ``"noise"``, ``"surrogate"``, ``"segments"`` or ``"posterior"`` (:data:`INTERVAL_METHODS`; never
        ``"auto"``); ``"posterior"`` also when the replicates could not be identified (see ``findings``).
    coefficients : tuple of ParameterInterval
        One per term, in the candidate's order.
    frequencies, damping_ratios : tuple of ParameterInterval
        One per full-record mode (empty with ``method = "posterior"``).
    n_segments : int
        Sub-records (or noise or model replicates) identified successfully.
    segment_samples : int
        Samples per sub-record or replicate (0 when none was used).
    findings : tuple of Finding
        Why the method fell back (``interval.fallback``), which sub-records or replicates failed
        (``interval.replicate_failed``), which posterior means lie outside the 95 % interval of the
        reported estimate (``interval.disagreement``), terms whose replicate bias is only partly
        the bias (``interval.discontinuous``), widening (``interval.widened``).
    widening : float
        Factor the intervals were widened by because the model does not reach the noise level
        (:func:`widen`); 1 when they were not.
    """

    method: str
    coefficients: tuple[ParameterInterval, ...]
    frequencies: tuple[ParameterInterval, ...] = ()
    damping_ratios: tuple[ParameterInterval, ...] = ()
    n_segments: int = 0
    segment_samples: int = 0
    findings: tuple[Finding, ...] = ()
    widening: float = 1.0

    def to_dict(self) -> dict:
        """JSON-ready record.

        Returns
        -------
        dict
            Method, per-parameter records, segments used and findings.
        """
        return {
            "method": self.method, **{key: [p.to_dict() for p in getattr(self, key)]
                                      for key in ("coefficients", "frequencies", "damping_ratios")},
            "n_segments": self.n_segments, "segment_samples": self.segment_samples,
            "findings": [f.to_dict() for f in self.findings],
            "widening": self.widening,
        }


def _interval(
    name: str, centre: float, posterior_sd: float, segment_sd: float, posterior_mean: float = math.nan
) -> ParameterInterval:
    centre, posterior_sd, segment_sd = float(centre), float(posterior_sd), float(segment_sd)
    parts = [s for s in (posterior_sd, segment_sd) if math.isfinite(s)]
    sd = math.sqrt(sum(s * s for s in parts)) if parts else math.nan
    return ParameterInterval(
        name=name, estimate=float(centre), sd=sd, posterior_sd=float(posterior_sd), segment_sd=float(segment_sd),
        ci50=(centre - _Z50 * sd, centre + _Z50 * sd), ci95=(centre - _Z95 * sd, centre + _Z95 * sd),
        posterior_mean=float(posterior_mean),
    )


def _disagreements(coefficients) -> tuple[Finding, ...]:
    """A finding per coefficient whose posterior mean lies outside the 95 % interval of the reported estimate."""
    return tuple(
        Finding("interval.disagreement",
                f"{p.name}: the posterior mean {p.posterior_mean:.4g} lies outside the 95 % interval "
                f"[{p.ci95[0]:.4g}, {p.ci95[1]:.4g}] of the NSI estimate {p.estimate:.4g}: the evidence's estimator "
                "and NSI disagree by more than their scatter (a bias neither interval carries)",
                p.name, "note", {"posterior_mean": p.posterior_mean, "estimate": p.estimate,
                                 "ci95_low": p.ci95[0], "ci95_high": p.ci95[1]})
        for p in coefficients
        if math.isfinite(p.posterior_mean) and not p.ci95[0] <= p.posterior_mean <= p.ci95[1]
    )


def _failed(failures) -> tuple[Finding, ...]:
    """A note per sub-record or replicate that could not be identified (``"label: error"``)."""
    return tuple(Finding("interval.replicate_failed", str(f), str(f).split(":", 1)[0], "note") for f in failures)


def _fallback(message: str) -> Finding:
    return Finding("interval.fallback", message, "", "warning")


def candidate_intervals(result, signals, evidence_result, options=None, nsi_options=None) -> Intervals:
    """50 % and 95 % intervals of a candidate's coefficients and modes (module notes).

    Parameters
    ----------
    result : NSIResult
        The identified candidate.
    signals : Signals
        The estimation data.
    evidence_result : EvidenceResult
        Its evidence under the primary likelihood (posterior draws of the coefficients).
    options : EvidenceOptions, optional
        ``interval``, ``n_segments`` and ``segment_fraction`` (default ``EvidenceOptions()``).
    nsi_options : NSIOptions, optional
        The settings ``result`` was identified with (default ``NSIOptions()``).

    Returns
    -------
    Intervals

    Warns
    -----
    IntervalWarning
        When fewer than two sub-records could be identified: the intervals are the posterior's
        alone and too narrow.
    """
    from ..options import EvidenceOptions

    options = options or EvidenceOptions()
    draws = np.asarray(evidence_result.posterior.coefficients, dtype=float)
    draws = draws.reshape(int(np.prod(draws.shape[:-1])), draws.shape[-1])  # also with no coefficient
    post_mean, post_sd = draws.mean(axis=0), draws.std(axis=0)
    names = tuple(evidence_result.coefficient_names)
    # the reported estimate: the NSI coefficient the model holds (the posterior mean where it has none)
    value = np.asarray(result.coefficient_values, dtype=float).reshape(-1)
    centres = value if value.shape == post_mean.shape else post_mean
    if options.interval == "posterior":
        return _posterior_only(names, draws, centres, ())
    if options.interval in ("noise", "surrogate", "auto"):
        found = _noise_intervals(result, signals, options, nsi_options, (names, centres, post_sd, post_mean))
        return found if found is not None else _posterior_only(names, draws, centres, (_fallback(_NOISE_FALLBACK),))
    n = signals.n_samples
    samples, coefs, freqs, zetas, failures = segment_estimates(
        result, signals, nsi_options, options.n_segments, options.segment_fraction
    )
    if len(coefs) < 2:
        note = (
            f"only {len(coefs)} of {options.n_segments} sub-records of {samples} samples could be identified "
            f"({failures[0] if failures else 'none tried'}); the intervals are the posterior's alone, conditional on "
            "the identified linear part, and too narrow: use a longer record or a larger segment_fraction"
        )
        fallback = _fallback(note)
        emit([fallback], IntervalWarning, stacklevel=2)
        return _posterior_only(names, draws, centres, (fallback,))
    coef_sd = scatter_sd(coefs, result.coefficient_values, samples, n)
    f_full = np.array([m.frequency_hz for m in result.modes])
    z_full = np.array([m.damping_ratio for m in result.modes])
    f_sd = scatter_sd(freqs, f_full, samples, n)
    z_sd = scatter_sd(zetas, z_full, samples, n)
    coefficients = tuple(
        _interval(nm, c, s, g, pm) for nm, c, s, g, pm in zip(names, centres, post_sd, coef_sd, post_mean)
    )
    return Intervals(
        method="segments",
        coefficients=coefficients,
        frequencies=tuple(_interval(f"f{k + 1}", f, math.nan, s) for k, (f, s) in enumerate(zip(f_full, f_sd))),
        damping_ratios=tuple(
            _interval(f"zeta{k + 1}", z, math.nan, s) for k, (z, s) in enumerate(zip(z_full, z_sd))
        ),
        n_segments=len(coefs),
        segment_samples=samples,
        findings=_failed(failures) + _disagreements(coefficients),
    )


def _posterior_only(names, draws: np.ndarray, centres, findings) -> Intervals:
    """The posterior's quantiles shifted onto the reported estimates (its spread about them)."""
    coefficients = []
    for k, name in enumerate(names):
        column = draws[:, k]
        mean, shift = float(column.mean()), float(centres[k]) - float(column.mean())
        q = np.quantile(column, [0.025, 0.25, 0.75, 0.975]) + shift
        coefficients.append(ParameterInterval(
            name=name, estimate=float(centres[k]), sd=float(column.std()), posterior_sd=float(column.std()),
            segment_sd=math.nan, ci50=(float(q[1]), float(q[2])), ci95=(float(q[0]), float(q[3])),
            posterior_mean=mean,
        ))
    found = tuple(coefficients)
    return Intervals(method="posterior", coefficients=found, findings=tuple(findings) + _disagreements(found))


_NOISE_FALLBACK = ("fewer than two replicates of the record could be identified; the intervals are the posterior's "
                   "alone, conditional on the identified linear part, and too narrow")


def _replicates(result, signals, options, nsi_options):
    """The replicates of ``options.interval`` (noise, model or "auto"): method, estimates, failures, findings."""
    from .replicates import discontinuity_findings, noise_replicates
    from .surrogate import holds_coulomb_friction, model_replicates, surrogate_problem

    problem = surrogate_problem(result, signals)
    wanted = options.interval == "surrogate" or (options.interval == "auto" and holds_coulomb_friction(result))
    notes: tuple[Finding, ...] = ()
    if wanted and problem is None:
        _, *found, failures = model_replicates(result, signals, nsi_options, options.n_replicates, options.seed)
        if len(found[0]) >= 2:
            return "surrogate", found, failures, ()
        why = failures[0] if failures else "none identified"
        notes = (Finding("interval.fallback", f"model replicates failed ({why}); noise replicates used instead", "",
                         "note"),)
    elif options.interval == "surrogate":
        notes = (_fallback(f"model replicates do not apply: {problem}; noise replicates used instead"),)
        emit(notes, IntervalWarning, stacklevel=4)
    _, *found, failures = noise_replicates(result, signals, nsi_options, options.n_replicates, options.seed)
    return "noise", found, failures, notes + discontinuity_findings(result)


def _noise_intervals(result, signals, options, nsi_options, posterior) -> Intervals | None:
    """Intervals from noise or model replicates; None (with a warning) when fewer than 2 identify."""
    from .replicates import replicate_moments

    names, centres, post_sd, post_mean = posterior
    method, (coefs, freqs, zetas), failures, notes = _replicates(result, signals, options, nsi_options)
    if len(coefs) < 2:
        emit([_fallback(f"{_NOISE_FALLBACK} ({failures[0] if failures else 'none tried'})")], IntervalWarning,
             stacklevel=3)
        return None
    f_full = np.array([m.frequency_hz for m in result.modes], dtype=float)
    z_full = np.array([m.damping_ratio for m in result.modes], dtype=float)
    out = []
    for full, reps, extra_sd, means, labels in (
        (np.asarray(centres, dtype=float), coefs, post_sd, post_mean, names),
        (f_full, freqs, np.full(len(f_full), math.nan), np.full(len(f_full), math.nan),
         [f"f{k + 1}" for k in range(len(f_full))]),
        (z_full, zetas, np.full(len(z_full), math.nan), np.full(len(z_full), math.nan),
         [f"zeta{k + 1}" for k in range(len(z_full))]),
    ):
        sd, bias, count = replicate_moments(full, reps)
        out.append(tuple(
            _bias_corrected(*row) for row in zip(labels, full, sd, bias, count, extra_sd, means)
        ))
    return Intervals(
        method=method, coefficients=out[0], frequencies=out[1], damping_ratios=out[2], n_segments=len(coefs),
        segment_samples=int(signals.n_samples), findings=_failed(failures) + _disagreements(out[0]) + notes,
    )


def _bias_corrected(name, estimate, rep_sd, bias, count, posterior_sd, posterior_mean) -> ParameterInterval:
    """Student-t intervals (count - 1 dof) about ``estimate - bias``; the 95 % one stretched to hold ``estimate``.

    The sd is the replicates' (with the bias estimate's own variance sd²/count) and the posterior's
    in quadrature. The 50 % interval is left central (stretching it over-covered: 74 % for the
    twin's v|v|); it excludes the reported value when the bias exceeds about 0.7 sd.
    """
    from scipy.stats import t as student_t

    estimate, rep_sd, bias, posterior_sd = float(estimate), float(rep_sd), float(bias), float(posterior_sd)
    if not (math.isfinite(rep_sd) and math.isfinite(bias)):
        rep_sd, bias, count = math.nan, 0.0, 2
    parts = [s for s in (rep_sd * math.sqrt(1.0 + 1.0 / int(count)), posterior_sd) if math.isfinite(s)]
    sd = math.sqrt(sum(s * s for s in parts)) if parts else math.nan
    centre = estimate - bias
    q95, q50 = (float(student_t.ppf(p, int(count) - 1)) for p in (0.975, 0.75))

    return ParameterInterval(
        name=name, estimate=estimate, sd=sd, posterior_sd=posterior_sd, segment_sd=rep_sd,
        ci50=(centre - q50 * sd, centre + q50 * sd),
        ci95=(min(centre - q95 * sd, estimate), max(centre + q95 * sd, estimate)),
        posterior_mean=float(posterior_mean), bias=bias,
    )
