"""Noise on the measured force of a periodic test: when it reaches the responses above their own noise.

Identification and evidence take the measured force as exact: the residual's noise is the response
sensors'. A force measured with noise of its own (a load cell's, a drive current's) enters
the responses through the structure, ``H(ω) N_f(ω)``, amplified at the resonances, and no candidate
can explain it. On a periodic record both noises show as the scatter between periods, line by line:
at line k the force's noise reaches output o at ``R_k = (σ²_F(k) / |F̄(k)|²) |Ȳ_o(k)|² / σ²_Y,o(k)``
times the output's own noise (one force: ``Ȳ = H F̄``). A simulated test (4-DOF chain, laser vibrometer, flat
multisine of 8 periods, 1 % velocity noise) with 0.5 % noise on the force: R > 1 on the lines holding
77-84 % of each response's power, and the superset true + Coulomb beat the true model by 26-258 nat
on 5 of 5 seeds; without the force noise the true model won on 4 of 5 (the fifth by 1.8 nat). With
0.1 % force noise the share was 2-15 %. :func:`force_noise_findings` warns from
:data:`FORCE_NOISE_SHARE`. The intervals carry it since the noise replicates draw the force's period
scatter with the responses' (:func:`bayesnsi.noise.noise_model`): f1 and ζ1 held
the truth on 2 of 5 seeds before (seeds 2-6; 4 of 11 over seeds 1-11) and on 6 of 6 after (seeds
1-6), and the adequacy yardstick no longer reads the force noise at the first mode as a missing
effect (2.1-2.8x the noise there before, no band warning after).
"""

from __future__ import annotations

import numpy as np

from ..findings import Finding
from ..nsi.periodic import period_spectra
from ..signals import Signals

__all__ = ["FORCE_NOISE_SHARE", "force_noise_findings"]

FORCE_NOISE_SHARE = 0.5
"""Share of a response channel's power on lines where the force's noise reaches it above the channel's own
noise (R_k > 1) from which the selection warns."""


def _shares(signals: Signals) -> tuple[np.ndarray, float] | None:
    """Per output channel, the power share of the lines with R_k > 1, and the force's noise over its level."""
    spectra = period_spectra(signals)
    if spectra.n_periods < 3:
        return None
    lines = spectra.lines()
    force_power = np.abs(spectra.force[lines, 0]) ** 2
    force_noise = spectra.force_var[lines, 0]
    response_power = np.abs(spectra.response[lines]) ** 2
    response_noise = spectra.response_var[lines]
    if not len(lines) or not np.all(np.isfinite(force_noise)) or np.sum(force_power) <= 0:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = (force_noise / force_power)[:, None] * response_power / response_noise
    reach = np.where(np.isfinite(reach), reach, 0.0)
    total = np.sum(response_power, axis=0)
    share = np.where(total > 0, np.sum(response_power * (reach > 1.0), axis=0) / np.where(total > 0, total, 1.0), 0.0)
    every = slice(1, None)  # all lines but DC: white force noise lies on the unexcited lines too
    level = float(np.sqrt(np.sum(spectra.force_var[every, 0]) * spectra.n_periods / np.sum(force_power)))
    return share, level


def force_noise_findings(signals: Signals) -> list[Finding]:
    """A finding when the measured force's noise reaches the responses above their own noise (module notes).

    Parameters
    ----------
    signals : Signals
        The estimation record; only a periodic one with one force and three or more periods per
        realisation is judged (each realisation on its own, the largest share counts).

    Returns
    -------
    list of Finding
        One finding (kind ``"data.force_noise"``, subject: the most affected output), or none.
    """
    if not signals.period or signals.force.shape[1] != 1:
        return []
    found = [s for record in signals.realisation_records() if (s := _shares(record)) is not None]
    if not found:
        return []
    share = np.max([s for s, _ in found], axis=0)
    level = max(lv for _, lv in found)
    worst = int(np.argmax(share))
    if share[worst] < FORCE_NOISE_SHARE:
        return []
    message = (
        f"the measured force scatters between periods by {100 * level:.2g} % of its level, and through the "
        "structure that noise reaches the responses above their own noise on the lines holding "
        f"{100 * share[worst]:.0f} % of the power of output {signals.output_names[worst]!r}: the identification "
        "and the evidence take the force as exact, so the evidence can favour a candidate whose extra term fits "
        "that noise (check that an extra term's interval excludes zero; the intervals and the adequacy check do "
        "carry the force's scatter); measure the force with less noise or average more periods"
    )
    values = {"force_scatter": level, "share": float(share[worst]), "limit": FORCE_NOISE_SHARE}
    return [Finding("data.force_noise", message, str(signals.output_names[worst]), "warning", values)]
