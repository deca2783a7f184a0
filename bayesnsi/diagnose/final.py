"""Evidence and honest intervals of the loop's final model (issue 15).

The loop decides with Laplace evidences and samples only the effects it accepts; their credible
intervals condition on the identified linear part. :func:`final_intervals` gives the final model
the intervals of ``bayesnsi select`` (:func:`bayesnsi.evidence.candidate_intervals`): the
posterior widened by the scatter (and errors-in-variables bias) of the whole identification over
noisy copies of the record or, for Coulomb friction, over records of the model
driven by phase-randomised forces (default ``interval = "auto"``), or record windows, re-identified with
the settings the final model was identified with (``settings["final_nsi"]``, upsampled for
velocity-switching terms).
"""

from __future__ import annotations

import numpy as np

from ..evidence import candidate_evidence, candidate_intervals
from ..options import EvidenceOptions, NSIOptions

__all__ = ["final_intervals"]


def final_intervals(loop, signals, evidence: EvidenceOptions | None = None, seed_sequence=None):
    """Posterior and 50 % / 95 % intervals (linear-part uncertainty included) of ``loop.final``.

    Parameters
    ----------
    loop : LoopResult
        The loop's outcome (:func:`bayesnsi.diagnose.close_the_loop`).
    signals : Signals
        The estimation data the loop ran on.
    evidence : EvidenceOptions, optional
        Evidence and interval settings, used as given (``bayesnsi diagnose`` passes the selection's,
        so the final evidence compares with the candidates'); default: those the loop recorded
        (``settings["evidence"]``, with the loop's residual). No other likelihood is computed.
    seed_sequence : numpy.random.SeedSequence, optional
        Seeds of the sampler (default: from ``evidence.seed``).

    Returns
    -------
    evidence_result : EvidenceResult
        The final model's evidence under the primary likelihood.
    intervals : Intervals
        Its coefficients and modes with their intervals (``method = "posterior"`` when the
        windows could not be identified, with an ``IntervalWarning``).
    """
    settings = loop.settings or {}
    if evidence is None:
        evidence = EvidenceOptions.from_mapping(settings.get("evidence") or {})
    options = evidence.replace(compare=())
    nsi = NSIOptions.from_mapping(settings["final_nsi"]) if settings.get("final_nsi") else NSIOptions()
    seeds = seed_sequence if seed_sequence is not None else np.random.SeedSequence(options.seed)
    result = candidate_evidence(loop.final, signals, options, seeds, warn=False)[options.likelihood]
    return result, candidate_intervals(loop.final, signals, result, options, nsi)
