"""Report tables of the honest intervals (issue 15): coefficients and modes with their 50 % / 95 % intervals.

The intervals are :attr:`CandidateOutcome.intervals` (:func:`bayesnsi.evidence.candidate_intervals`):
the coefficient posterior widened by the scatter of the whole identification over record windows,
so they include the uncertainty of the identified linear part. The posterior-only interval (given
the linear part as if it were exact) is shown beside them and labelled so.
"""

from __future__ import annotations

import math

__all__ = [
    "INTERVAL_TEXT", "NOISE_TEXT", "SURROGATE_TEXT", "coefficient_intervals_frame", "mode_intervals_frame",
    "interval_text", "interval_sections", "final_coefficients_frame", "format_interval",
]

INTERVAL_TEXT = (
    "95 % and 50 % intervals include the uncertainty of the identified linear part: the whole identification is "
    "repeated on {n} windows of {samples} samples of the record and their scatter (delete-a-block jackknife) is added "
    "to the posterior variance of the coefficients. The posterior-only interval beside it conditions on the "
    "identified linear part as if it were exact and is too narrow (issue 15). A bias shared by every window "
    "(e.g. errors-in-variables bias) is not included."
)
NOISE_TEXT = (
    "95 % and 50 % intervals include the uncertainty of the identified linear part: the whole identification is "
    "repeated on {n} copies of the record with fresh sensor noise added at the level estimated from the data; their "
    "scatter gives the sd (Student-t quantiles, {dof} degrees of freedom) and their mean shift the errors-in-variables "
    "bias, removed from the interval's centre (SIMEX); each interval is stretched to hold the reported NSI estimate. "
    "The posterior-only interval beside it conditions on the identified linear part as if it were exact and is too "
    "narrow (issue 15). Error that does not come from the sensor noise (discretisation, a structure outside the model, "
    "coloured or force-side noise) is not included."
)
SURROGATE_TEXT = (
    "For {names} (Coulomb friction, a sign() of a velocity) the identification is repeated instead on {n} "
    "records of the identified model driven by copies of the measured force with fresh random phases, with sensor "
    "noise added at the data's level (docs/method.md §11): their scatter and mean shift also carry the bias that "
    "varies with where the velocity reverses, which noise added to the measured record re-randomises."
)
_LABELS = {"segments": "windows + posterior", "noise": "noise replicates + posterior",
           "surrogate": "model replicates + posterior"}
_POSTERIOR_TEXT = (
    "The intervals are the coefficient posterior's alone, given the identified linear part as if it were exact: "
    "they do not include the linear part's uncertainty and are too narrow."
)


def format_interval(ci) -> str:
    """``[lo, hi]`` with enough significant digits to show the width (at least 4, two in the width).

    Parameters
    ----------
    ci : sequence of two floats

    Returns
    -------
    str
        ``"—"`` when a bound is not finite.
    """
    lo, hi = float(ci[0]), float(ci[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "—"
    span, size = abs(hi - lo), max(abs(lo), abs(hi))
    digits = 4 if span == 0.0 or size == 0.0 else max(4, math.ceil(math.log10(size / span)) + 2)
    return f"[{lo:.{digits}g}, {hi:.{digits}g}]"


_pair = format_interval


def interval_text(outcomes) -> str:
    """What the report's intervals include, worded from the first outcome that carries intervals.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome

    Returns
    -------
    str
        Empty when no outcome carries intervals.
    """
    for outcome in outcomes:
        iv = getattr(outcome, "intervals", None)
        if iv is None:
            continue
        if iv.method == "segments":
            text = INTERVAL_TEXT.format(n=iv.n_segments, samples=iv.segment_samples)
        elif iv.method in ("noise", "surrogate"):
            text = NOISE_TEXT.format(n=iv.n_segments, dof=iv.n_segments - 1) + _discontinuity_text(outcomes)
            model = [o.name for o in outcomes if getattr(getattr(o, "intervals", None), "method", None) == "surrogate"]
            text += " " + SURROGATE_TEXT.format(names=", ".join(model), n=iv.n_segments) if model else ""
        else:
            text = _POSTERIOR_TEXT + (" " + " ".join(iv.notes) if iv.notes else "")
        return text + _widened_text(outcomes)
    return ""


def _discontinuity_text(outcomes) -> str:
    """The note of :func:`bayesnsi.evidence.perturbation.discontinuity_notes` for the candidates it concerns."""
    from ..evidence.perturbation import discontinuity_notes

    notes: dict[str, list[str]] = {}
    for outcome in outcomes:
        if getattr(getattr(outcome, "intervals", None), "method", None) == "noise":
            for note in discontinuity_notes(getattr(outcome, "result", None)):
                notes.setdefault(note, []).append(outcome.name)
    return "".join(f" {', '.join(names)}: {note}." for note, names in notes.items())


def _widened_text(outcomes) -> str:
    """A sentence naming the candidates whose intervals were widened for their model error."""
    wide = [(o.name, o.intervals.widening) for o in outcomes
            if getattr(o, "intervals", None) is not None and getattr(o.intervals, "widening", 1.0) > 1.0]
    if not wide:
        return ""
    listed = ", ".join(f"{name} {factor:.2f}x" for name, factor in wide)
    return (f" Widened for model error (residual above the noise the model passes on, so the model error, not the "
            f"noise, moves the estimates from record to record; docs/method.md §11): {listed}.")


def coefficient_intervals_frame(outcomes, likelihood: str):
    """One row per candidate and coefficient: estimate, sd, honest 50 % / 95 % and posterior-only 95 %.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    likelihood : str
        The primary likelihood (its posterior gives the posterior-only interval).

    Returns
    -------
    pandas.DataFrame or None
        None when no candidate has a coefficient with intervals.
    """
    import pandas as pd

    rows = []
    for outcome in outcomes:
        iv = getattr(outcome, "intervals", None)
        if iv is None or not iv.coefficients:
            continue
        evidence = (outcome.evidences or {}).get(likelihood)
        posterior = [] if evidence is None else list(evidence.ci95)
        for k, p in enumerate(iv.coefficients):
            rows.append({
                "candidate": outcome.name,
                "coefficient": p.name,
                "estimate": p.estimate,
                "sd": p.sd,
                "95 % interval": _pair(p.ci95),
                "50 % interval": _pair(p.ci50),
                "95 % posterior only (given the linear part)": _pair(posterior[k]) if k < len(posterior) else "—",
                "interval": _LABELS.get(iv.method, "posterior only"),
            })
    if not rows:
        return None
    return pd.DataFrame(rows).set_index(["candidate", "coefficient"])


def mode_intervals_frame(outcomes):
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
        iv = getattr(outcome, "intervals", None)
        if iv is None or not iv.frequencies:
            continue
        for k, (f, z) in enumerate(zip(iv.frequencies, iv.damping_ratios)):
            rows.append({
                "candidate": outcome.name,
                "mode": k + 1,
                "frequency [Hz]": f.estimate,
                "frequency 95 % interval": _pair(f.ci95),
                "frequency 50 % interval": _pair(f.ci50),
                "damping ratio [%]": 100 * z.estimate,
                "damping 95 % interval [%]": _pair([100 * v for v in z.ci95]),
                "damping 50 % interval [%]": _pair([100 * v for v in z.ci50]),
            })
    if not rows:
        return None
    return pd.DataFrame(rows).set_index(["candidate", "mode"])


def interval_sections(report, outcomes, selected, likelihood: str, answer: list, order: int) -> None:
    """The selected model's coefficients with intervals in the answer, and the section of all intervals.

    Parameters
    ----------
    report : Report
    outcomes : sequence of CandidateOutcome
    selected : str or None
        The candidate the answer presents.
    likelihood : str
        The primary likelihood.
    answer : list
        The answer section's blocks.
    order : int
        Place of the intervals section in the document.
    """
    chosen = [o for o in outcomes if o.name == selected and getattr(o, "intervals", None) is not None]
    if chosen and chosen[0].intervals.coefficients:
        iv = chosen[0].intervals
        evidence = (chosen[0].evidences or {}).get(likelihood)
        posterior = [] if evidence is None else list(evidence.ci95)
        parts = []
        for k, p in enumerate(iv.coefficients):
            text = f"{p.name} = {p.estimate:.4g}, 95 % interval {_pair(p.ci95)}"
            if iv.method in _LABELS and k < len(posterior):
                text += f" (posterior only, given the linear part: {_pair(posterior[k])})"
            parts.append(text)
        what = {"segments": "linear-part uncertainty from the record windows + posterior",
                "noise": "linear-part uncertainty and errors-in-variables bias from noise replicates + posterior",
                "surrogate": "linear-part uncertainty and errors-in-variables bias from model replicates on "
                             "phase-randomised forces + posterior"}.get(
            iv.method, "posterior only, given the linear part: too narrow")
        answer.append(f"Coefficients of {selected}: " + "; ".join(parts) + f". Intervals include: {what}.")
    coefficients, modes = coefficient_intervals_frame(outcomes, likelihood), mode_intervals_frame(outcomes)
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


def final_coefficients_frame(records):
    """The loop's final coefficients (results.json ``final_coefficients``) with their intervals, readable.

    Parameters
    ----------
    records : list of dict
        ``term``, ``value``, ``imag_ratio`` and, when computed, ``estimate``, ``sd``, ``ci95``,
        ``ci50`` (centred on the NSI value), ``posterior_mean``, ``ci95_posterior`` and ``interval``.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    rows = {}
    for r in records:
        row = {"coefficient λ (NSI)": r["value"], "|Im|/|Re|": r["imag_ratio"]}
        if "ci95" in r:
            row.update({
                "posterior mean": r.get("posterior_mean", math.nan), "sd": r["sd"], "95 % interval": _pair(r["ci95"]),
                "50 % interval": _pair(r["ci50"]),
                "95 % posterior only (given the linear part)": _pair(r.get("ci95_posterior", (math.nan, math.nan))),
                "interval": _LABELS.get(r["interval"], "posterior only"),
            })
        rows[r["term"]] = row
    return pd.DataFrame(rows).T.rename_axis("term")
