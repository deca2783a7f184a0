"""What the report shows, chosen from the data: the FRF figures' band, the overlays' channels, how the
displacements were obtained, and the sentence naming a plausible model."""

from __future__ import annotations

import numpy as np

__all__ = ["frf_band", "inadequacy_note", "measured_text", "overlay_channels", "plausible_text"]


def plausible_text(selection, selected, decision) -> str:
    """What the answer adds when the selected model fails a physical check (``Selection.plausible``)."""
    checks = selection.checks
    if selected not in checks or selected != selection.selected:
        return ""  # a loop's start (diagnose --start) is not the evidence's choice: nothing to set beside it
    plausible = selection.plausible
    if plausible == selected:
        return ""
    text = (f" But {selected} fails a physical check (below: quality index or negative dissipation), so it is "
            "not a physical model of the structure")
    if plausible is None:
        return text + "; no candidate passes every check."
    behind = decision.loc[plausible, "log_bayes_factor"] if plausible in decision.index else float("nan")
    return text + (f"; of the candidates that pass every check the most probable is {plausible}"
                   + (f" ({behind:.3g} nat behind)" if np.isfinite(behind) else "")
                   + inadequacy_note(checks.get(plausible)) + ".")


def inadequacy_note(check) -> str:
    """``", but its residual is N x the noise it passes on (not adequate)"`` for an inadequate model, else ``""``."""
    if check is None or check.adequate or not np.isfinite(check.noise_ratio):
        return ""
    return f", but its residual is {check.noise_ratio:.3g}x the noise it passes on (not adequate either)"


def measured_text(config) -> str:
    """How the displacements were obtained when the sensors measured something else (``[data] integrate``)."""
    data = config.data
    spec = data.integrate
    if spec is None:
        return ""
    what = data.integrated or "acceleration"
    times, plural = ("twice", "accelerations") if what == "acceleration" else ("once", "velocities")
    text = (f" (integrated {times} from the measured {plural} on load, {spec.method} method, band "
            f"[{spec.band_hz[0]:g}, {spec.band_hz[1]:g}] Hz: motion below {spec.band_hz[0]:g} Hz is lost")
    if data.period is None and spec.trim_edges:
        text += ", the integration's edges dropped from each window"
    return text + ")"


def frf_band(signals, results):
    """Upper frequency of the FRF figures, the data's H1 FRF (None if the record is too short), log axis or not.

    The figures reach over the band the force excites (99 % of its power), not only to 1.3x the highest
    identified mode: a mode the models lack shows there as a peak of the data.
    """
    from ..curves import measured_frf
    from ..exceptions import InputDataError

    # free bodies may have no oscillatory mode: the band of the identification then sets the axis
    modes = [m.frequency_hz for r in results.values() for m in r.modes]
    fmax = 1.3 * max(modes or [r.band_hz[1] for r in results.values()])
    try:
        measured = measured_frf(signals)
    except InputDataError:
        return fmax, None, False
    fmax = max(fmax, min(measured.excited_hz, 0.5 * float(signals.fs)))
    return fmax, measured, bool(modes) and fmax > 8 * min(modes)


def overlay_channels(signals, terms, limit: int = 3) -> list[int]:
    """Output channels of the measured-vs-model overlays: the first, then where the terms act.

    Parameters
    ----------
    signals : Signals
    terms : iterable of Term
        The nonlinear terms of the models shown.
    limit : int
        At most this many channels.

    Returns
    -------
    list of int
        Indices into ``signals.output_dofs``.
    """
    outputs = list(signals.output_dofs)
    chosen = [0]
    for term in terms:
        for dof in term.at:
            if dof in outputs and outputs.index(dof) not in chosen:
                chosen.append(outputs.index(dof))
    if len(chosen) == 1 and len(outputs) > 1:  # linear models only: the first two outputs, as before
        chosen.append(1)
    return chosen[:limit]
