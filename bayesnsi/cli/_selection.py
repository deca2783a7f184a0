"""Selection pipeline shared by ``select``, ``demo`` and ``diagnose``: NSI + evidence + ranking."""

from __future__ import annotations

import numpy as np

from ._common import identify_all

__all__ = ["select_all"]


def select_all(config, signals, quiet=False, jobs: int = 1, **run_options):
    """Identify every candidate, compute evidences and rank (SPEC 6), on ``jobs`` processes.

    ``run_options`` (``scheduler``, ``cache``) are passed to :func:`identify_all`.

    Returns
    -------
    results : dict name -> NSIResult
    records : list of dict (results.json candidate records with evidence fields)
    evidences : dict name -> dict likelihood -> EvidenceResult
    table : pandas.DataFrame (plain ranking and posterior probabilities side by side)
    opts : EvidenceOptions (evidence settings used)
    """
    from ..evidence import compare_evidence

    opts = config.evidence
    results, records, evidences = identify_all(
        config, signals, quiet=quiet, jobs=jobs, evidence_options=opts, **run_options
    )
    table = compare_evidence(
        {c.name: list(evidences[c.name].values()) if c.name in evidences else None for c in config.candidates},
        priors=[c.prior for c in config.candidates],
        rng=np.random.default_rng(np.random.SeedSequence(config.seed).spawn(len(config.candidates) + 1)[-1]),
    )
    lik = opts.likelihood
    for record in records:
        name = record["name"]
        row = table.loc[name]
        record["log_likelihood_gaussian"] = _finite(row["log_likelihood_plain"])
        record["posterior_gaussian"] = float(row["p_plain"])
        if name in evidences:
            ev = evidences[name][lik]
            record.update(
                log_evidence=ev.log_evidence,
                log_evidence_se=ev.log_evidence_se,
                log_evidence_laplace=ev.laplace_log_evidence,
                log_evidence_closed_form=ev.closed_form_log_evidence,
                posterior=float(row[f"p_{lik}"]),
                posterior_sd=float(row[f"p_{lik}_sd"]),
                rhat_max=ev.rhat_max,
                ess_min=ev.ess_min,
                likelihood=lik,
                evidence_by_likelihood={
                    k: {"log_evidence": e.log_evidence, "log_evidence_se": e.log_evidence_se, "posterior": float(row[f"p_{k}"])}
                    for k, e in evidences[name].items()
                },
            )
            for coef, ci in zip(record["coefficients"], ev.ci95):
                coef["ci95"] = [float(ci[0]), float(ci[1])]
        else:
            record.update(log_evidence=None, log_evidence_se=None, posterior=0.0, rhat_max=None, ess_min=None)
    return results, records, evidences, table, opts


def _finite(value):
    value = float(value)
    return value if np.isfinite(value) else None
