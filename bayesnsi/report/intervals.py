"""The honest intervals in the report: coefficients and modes with their 50 % / 95 % intervals.

The intervals are :class:`~bayesnsi.uncertainty.Intervals` (:func:`bayesnsi.uncertainty.candidate_intervals`):
the coefficient posterior widened by the scatter of the whole identification over noise
replicates, model replicates or record windows, so they include the uncertainty of the identified
linear part. "95 % interval" means that interval on every surface; the posterior-only interval
(given the linear part as if it were exact) is shown beside it under that name.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from ..io.units import ChannelUnits
from .document import Report
from .sections import MODELS
from .text import INTERVAL_LABELS, format_interval, term_label

__all__ = [
    "INTERVAL_TEXT", "NOISE_TEXT", "SURROGATE_TEXT", "coefficient_intervals_frame", "coefficient_sentence",
    "interval_sections", "interval_text", "mode_intervals_frame", "mode_sentence",
]

INTERVAL_TEXT = (
    "95 % and 50 % intervals include the uncertainty of the identified linear part: the whole identification is "
    "repeated on {n} windows of {samples} samples of the record and their scatter (delete-a-block jackknife) is added "
    "to the posterior variance of the coefficients. The posterior-only interval beside it conditions on the "
    "identified linear part as if it were exact and is too narrow. A bias shared by every window "
    "(e.g. errors-in-variables bias) is not included."
)
NOISE_TEXT = (
    "95 % and 50 % intervals include the uncertainty of the identified linear part: the whole identification is "
    "repeated on {n} copies of the record with fresh sensor noise added at the level estimated from the data; their "
    "scatter gives the sd (Student-t quantiles, {dof} degrees of freedom) and their mean shift the errors-in-variables "
    "bias, removed from the interval's centre (SIMEX); each interval is stretched to hold the reported NSI estimate. "
    "The posterior-only interval beside it conditions on the identified linear part as if it were exact and is too "
    "narrow. Error that does not come from the sensor noise (discretisation, a structure outside the model, "
    "coloured or force-side noise) is not included."
)
SURROGATE_TEXT = (
    "For {names} (Coulomb friction, a sign() of a velocity) the identification is repeated instead on {n} "
    "records of the identified model driven by copies of the measured force with fresh random phases, with sensor "
    "noise added at the data's level (docs/method.md §11): their scatter and mean shift also carry the bias that "
    "varies with where the velocity reverses, which noise added to the measured record re-randomises."
)
_POSTERIOR_TEXT = (
    "The intervals are the coefficient posterior's alone, given the identified linear part as if it were exact: "
    "they do not include the linear part's uncertainty and are too narrow."
)
_INCLUDES = {
    "segments": "linear-part uncertainty from the record windows + posterior",
    "noise": "linear-part uncertainty and errors-in-variables bias from noise replicates + posterior",
    "surrogate": "linear-part uncertainty and errors-in-variables bias from model replicates on phase-randomised "
                 "forces + posterior",
}


def coefficient_sentence(name: str, intervals, units: ChannelUnits | None = None) -> str:
    """``"Coefficients of X: term [unit] = v, 95 % interval [a, b]; ..."`` with what the intervals include.

    Parameters
    ----------
    name : str
        The model's name.
    intervals : Intervals
    units : ChannelUnits, optional

    Returns
    -------
    str
        Empty without coefficients.
    """
    if intervals is None or not intervals.coefficients:
        return ""
    parts = [f"{term_label(p.name, units)} = {p.estimate:.4g}, 95 % interval {format_interval(p.ci95)}"
             for p in intervals.coefficients]
    what = _INCLUDES.get(intervals.method, "posterior only, given the linear part: too narrow")
    widened = f"; widened {intervals.widening:.2f}x for model error" if intervals.widening > 1.0 else ""
    return f"Coefficients of {name}: " + "; ".join(parts) + f". Intervals include: {what}{widened}."


def mode_sentence(intervals) -> str:
    """``"Modes: 2.46 Hz [2.45, 2.47], ζ 0.91 % [0.85, 0.97]; ..."`` from a model's intervals.

    Parameters
    ----------
    intervals : Intervals

    Returns
    -------
    str
        Empty without modal intervals.
    """
    if intervals is None or not intervals.frequencies:
        return ""
    parts = [
        f"{f.estimate:.4g} Hz {format_interval(f.ci95)}, ζ {100 * z.estimate:.3g} % {format_interval(z.ci95, 100)}"
        for f, z in zip(intervals.frequencies, intervals.damping_ratios)
    ]
    return "Natural frequencies and damping ratios with 95 % intervals: " + "; ".join(parts) + "."


def interval_text(outcomes: Sequence) -> str:
    """What the report's intervals include, worded from the first outcome that carries intervals.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome (or any objects with ``name``, ``result``, ``intervals``)

    Returns
    -------
    str
        Empty when no outcome carries intervals.
    """
    for outcome in outcomes:
        iv = outcome.intervals
        if iv is None:
            continue
        if iv.method == "segments":
            text = INTERVAL_TEXT.format(n=iv.n_segments, samples=iv.segment_samples)
        elif iv.method in ("noise", "surrogate"):
            text = NOISE_TEXT.format(n=iv.n_segments, dof=iv.n_segments - 1) + _discontinuity_text(outcomes)
            model = [o.name for o in outcomes if o.intervals is not None and o.intervals.method == "surrogate"]
            text += " " + SURROGATE_TEXT.format(names=", ".join(model), n=iv.n_segments) if model else ""
        else:
            text = _POSTERIOR_TEXT + "".join(f" {f.message}" for f in iv.findings if f.kind == "interval.fallback")
        return text + _widened_text(outcomes)
    return ""


def _discontinuity_text(outcomes: Sequence) -> str:
    """The ``interval.discontinuous`` findings of the candidates with noise replicates, named."""
    notes: dict[str, list[str]] = {}
    for outcome in outcomes:
        if outcome.intervals is not None and outcome.intervals.method == "noise":
            for finding in outcome.intervals.findings:
                if finding.kind == "interval.discontinuous":
                    notes.setdefault(finding.message, []).append(outcome.name)
    return "".join(f" {', '.join(names)}: {note}." for note, names in notes.items())


def _widened_text(outcomes: Sequence) -> str:
    """A sentence naming the candidates whose intervals were widened for their model error."""
    wide = [(o.name, o.intervals.widening) for o in outcomes if o.intervals is not None and o.intervals.widening > 1.0]
    if not wide:
        return ""
    listed = ", ".join(f"{name} {factor:.2f}x" for name, factor in wide)
    return (f" Widened for model error (residual above the noise the model passes on, so the model error, not the "
            f"noise, moves the estimates from record to record; docs/method.md §11): {listed}.")


def coefficient_intervals_frame(outcomes: Sequence, likelihood: str, units: ChannelUnits | None = None):
    """One row per candidate and coefficient: estimate, sd, honest 50 % / 95 % and posterior-only 95 %.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    likelihood : str
        The primary likelihood (its posterior gives the posterior-only interval).
    units : ChannelUnits, optional

    Returns
    -------
    pandas.DataFrame or None
        None when no candidate has a coefficient with intervals.
    """
    import pandas as pd

    rows = []
    for outcome in outcomes:
        iv = outcome.intervals
        if iv is None or not iv.coefficients:
            continue
        evidence = (outcome.evidences or {}).get(likelihood)
        posterior = [] if evidence is None else list(evidence.ci95)
        for k, p in enumerate(iv.coefficients):
            rows.append({
                "candidate": outcome.name,
                "coefficient": term_label(p.name, units),
                "estimate": p.estimate,
                "sd": p.sd,
                "95 % interval": format_interval(p.ci95),
                "50 % interval": format_interval(p.ci50),
                "95 % given the linear part": format_interval(posterior[k]) if k < len(posterior) else "—",
                "interval": INTERVAL_LABELS.get(iv.method, iv.method),
            })
    if not rows:
        return None
    return pd.DataFrame(rows).set_index(["candidate", "coefficient"])


def mode_intervals_frame(outcomes: Sequence):
    """One row per candidate and mode: natural frequency and damping ratio with 95 % / 50 % intervals.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome

    Returns
    -------
    pandas.DataFrame or None
        None when no candidate carries modal intervals.
    """
    import pandas as pd

    rows = []
    for outcome in outcomes:
        iv = outcome.intervals
        if iv is None or not iv.frequencies:
            continue
        for k, (f, z) in enumerate(zip(iv.frequencies, iv.damping_ratios)):
            rows.append({
                "candidate": outcome.name,
                "mode": k + 1,
                "frequency [Hz]": f.estimate,
                "frequency 95 % interval": format_interval(f.ci95),
                "frequency 50 % interval": format_interval(f.ci50),
                "damping ratio [%]": 100 * z.estimate,
                "damping 95 % interval [%]": format_interval(z.ci95, 100),
                "damping 50 % interval [%]": format_interval(z.ci50, 100),
            })
    if not rows:
        return None
    return pd.DataFrame(rows).set_index(["candidate", "mode"])


def interval_sections(report: Report, outcomes: Sequence, likelihood: str, units: ChannelUnits | None = None,
                      order: int = MODELS) -> None:
    """The section of every candidate's intervals of coefficients and modes.

    Parameters
    ----------
    report : Report
    outcomes : sequence of CandidateOutcome
    likelihood : str
        The primary likelihood.
    units : ChannelUnits, optional
    order : int
        Place of the section.
    """
    coefficients, modes = coefficient_intervals_frame(outcomes, likelihood, units), mode_intervals_frame(outcomes)
    if coefficients is None and modes is None:
        return
    section = report.section("Intervals of coefficients and modes", order)
    section.append(interval_text(outcomes))
    if coefficients is not None:
        section.append(coefficients)
    if modes is not None:
        section.append("Natural frequencies and damping ratios of each candidate's underlying linear model with the "
                       "intervals from the scatter of the identification (noise replicates or record windows).")
        section.append(modes)


def final_coefficients_frame(final, units: ChannelUnits | None = None):
    """The loop's final coefficients with their intervals, readable.

    Parameters
    ----------
    final : FinalModel
        :attr:`bayesnsi.Diagnosis.final`.
    units : ChannelUnits, optional

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    intervals = final.intervals
    posterior = [] if final.evidence is None else list(final.evidence.ci95)
    rows = {}
    for k, c in enumerate(final.result.coefficients):
        row = {"coefficient λ (NSI)": c.value, "|Im|/|Re|": c.imag_ratio}
        if intervals is not None and k < len(intervals.coefficients):
            p = intervals.coefficients[k]
            row.update({
                "sd": p.sd, "95 % interval": format_interval(p.ci95), "50 % interval": format_interval(p.ci50),
                "95 % given the linear part": format_interval(posterior[k]) if k < len(posterior) else "—",
                "interval": INTERVAL_LABELS.get(intervals.method, intervals.method),
            })
        rows[term_label(c.term.name, units)] = row
    frame = pd.DataFrame(rows).T.rename_axis("term")
    return frame.replace({math.nan: None}) if frame.empty else frame
