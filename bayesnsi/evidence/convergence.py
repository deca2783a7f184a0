"""Convergence diagnostics of the posterior draws via arviz (docs/method.md §6).

``r_hat`` (rank-normalised split R-hat) and bulk/tail effective sample sizes come from
``arviz_stats`` on the arviz ``DataTree`` of the draws, one chain per emcee walker. The docs/method.md §6
criteria are ``r_hat <= 1.01`` and ``ESS >= 400`` for every parameter; otherwise a
:class:`~bayesnsi.exceptions.ConvergenceWarning` carries the numbers and the advice.

Walkers of an ensemble sampler are not independent chains, so these diagnostics are
approximate (emcee's authors say as much); the emcee autocorrelation time is reported beside
them in :class:`~bayesnsi.evidence.PosteriorSamples`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import ConvergenceWarning

__all__ = ["ConvergenceReport", "posterior_summary", "convergence_report", "warn_if_unconverged"]

RHAT_THRESHOLD = 1.01
ESS_THRESHOLD = 400.0
_SAMPLE_DIMS = ["chain", "draw"]


@dataclass(frozen=True)
class ConvergenceReport:
    """Worst-case convergence numbers of one run.

    Attributes
    ----------
    rhat_max : float
        Largest ``r_hat`` over parameters.
    ess_bulk_min, ess_tail_min : float
        Smallest bulk and tail effective sample sizes.
    worst_rhat, worst_ess : str
        Parameters where those extremes occur.
    rhat_threshold, ess_threshold : float
        Criteria applied (default 1.01 and 400).
    n_chains, n_draws : int
        Size of the run (chains = walkers, draws after burn-in).
    """

    rhat_max: float
    ess_bulk_min: float
    ess_tail_min: float
    worst_rhat: str
    worst_ess: str
    rhat_threshold: float = RHAT_THRESHOLD
    ess_threshold: float = ESS_THRESHOLD
    n_chains: int = 0
    n_draws: int = 0

    @property
    def ess_min(self) -> float:
        """``min(ess_bulk_min, ess_tail_min)``."""
        return float(min(self.ess_bulk_min, self.ess_tail_min))

    @property
    def converged(self) -> bool:
        """True when every parameter meets both criteria."""
        return bool(self.rhat_max <= self.rhat_threshold and self.ess_min >= self.ess_threshold)

    def message(self) -> str:
        """What failed, by how much, and what to do.

        Returns
        -------
        str
        """
        parts = []
        if not self.rhat_max <= self.rhat_threshold:
            parts.append(f"r_hat = {self.rhat_max:.4f} > {self.rhat_threshold} (worst: {self.worst_rhat})")
        if not self.ess_min >= self.ess_threshold:
            parts.append(f"ESS = {self.ess_min:.0f} < {self.ess_threshold:.0f} (worst: {self.worst_ess})")
        if not parts:
            return f"converged: r_hat <= {self.rhat_max:.4f}, ESS >= {self.ess_min:.0f}"
        factor = 2.0
        if np.isfinite(self.ess_min) and self.ess_min > 0:
            factor = max(2.0, self.ess_threshold / self.ess_min * 1.2)
        return (
            "MCMC not converged: " + "; ".join(parts) + f" with {self.n_chains} walkers x {self.n_draws} draws. "
            f"Run about {factor:.0f}x more steps (n_steps) or more walkers (n_walkers), "
            "or increase the burn-in (n_burn)."
        )


def posterior_summary(datatree, ci_prob: float = 0.95):
    """Summary table of the posterior draws: mean, sd, HDI, ess_bulk, ess_tail, r_hat, MCSE.

    Parameters
    ----------
    datatree : xarray.DataTree
        From :meth:`PosteriorSamples.to_datatree`; group ``posterior`` with dims
        ``(chain, draw, ...)``.
    ci_prob : float, default 0.95
        Probability mass of the highest-density interval.

    Returns
    -------
    pandas.DataFrame
        One row per scalar parameter (labels as arviz writes them, e.g. ``coefficient[k3]``);
        columns ``mean, sd, hdi{P}_lb, hdi{P}_ub, ess_bulk, ess_tail, r_hat, mcse_mean,
        mcse_sd`` with ``P = 100 ci_prob``; unrounded.

    Notes
    -----
    Assembled from the ``azstats`` dataset accessor (``hdi``, ``ess``, ``rhat``, ``mcse``) and
    ``arviz_base.dataset_to_dataframe``, as ``arviz_stats.summary`` does, but with the interval
    computed by ``hdi``: ``arviz_stats.summary(ci_kind="hdi")`` 0.8 labels an equal-tailed
    interval as HDI.
    """
    import arviz_stats  # noqa: F401  (registers the ``azstats`` accessor)
    import xarray as xr
    from arviz_base import dataset_to_dataframe

    ds = datatree["posterior"].to_dataset()
    perc = int(round(100 * ci_prob))
    pieces = [
        ds.mean(dim=_SAMPLE_DIMS).expand_dims(summary=["mean"]),
        ds.std(dim=_SAMPLE_DIMS).expand_dims(summary=["sd"]),
        ds.azstats.hdi(prob=ci_prob, dim=_SAMPLE_DIMS)
        .rename({"ci_bound": "summary"})
        .assign_coords(summary=[f"hdi{perc}_lb", f"hdi{perc}_ub"]),
        ds.azstats.ess(sample_dims=_SAMPLE_DIMS, method="bulk").expand_dims(summary=["ess_bulk"]),
        ds.azstats.ess(sample_dims=_SAMPLE_DIMS, method="tail").expand_dims(summary=["ess_tail"]),
        ds.azstats.rhat(sample_dims=_SAMPLE_DIMS).expand_dims(summary=["r_hat"]),
        ds.azstats.mcse(sample_dims=_SAMPLE_DIMS, method="mean").expand_dims(summary=["mcse_mean"]),
        ds.azstats.mcse(sample_dims=_SAMPLE_DIMS, method="sd").expand_dims(summary=["mcse_sd"]),
    ]
    table = xr.concat(pieces, dim="summary")
    return dataset_to_dataframe(table, sample_dims=["summary"]).T.astype(float)


def convergence_report(
    summary, rhat_threshold: float = RHAT_THRESHOLD, ess_threshold: float = ESS_THRESHOLD, n_chains=0, n_draws=0
) -> ConvergenceReport:
    """Worst ``r_hat`` and ESS of a :func:`posterior_summary` table.

    Parameters
    ----------
    summary : pandas.DataFrame
        With columns ``r_hat``, ``ess_bulk``, ``ess_tail``.
    rhat_threshold, ess_threshold : float
        Criteria (docs/method.md §6 defaults 1.01 and 400).
    n_chains, n_draws : int
        Run size, quoted in the advice.

    Returns
    -------
    ConvergenceReport
        NaN diagnostics (e.g. a parameter that never moved) count as failures.
    """
    rhat = summary["r_hat"].astype(float).fillna(np.inf)
    ess = np.minimum(summary["ess_bulk"].astype(float), summary["ess_tail"].astype(float)).fillna(0.0)
    return ConvergenceReport(
        rhat_max=float(rhat.max()),
        ess_bulk_min=float(summary["ess_bulk"].astype(float).fillna(0.0).min()),
        ess_tail_min=float(summary["ess_tail"].astype(float).fillna(0.0).min()),
        worst_rhat=str(rhat.idxmax()),
        worst_ess=str(ess.idxmin()),
        rhat_threshold=float(rhat_threshold),
        ess_threshold=float(ess_threshold),
        n_chains=int(n_chains),
        n_draws=int(n_draws),
    )


def warn_if_unconverged(report: ConvergenceReport, context: str = "", stacklevel: int = 2) -> bool:
    """Issue a :class:`ConvergenceWarning` with the numbers when the criteria are not met.

    Parameters
    ----------
    report : ConvergenceReport
    context : str
        Prefix naming the candidate or likelihood.
    stacklevel : int
        Passed to :func:`warnings.warn`.

    Returns
    -------
    bool
        True if a warning was issued.
    """
    if report.converged:
        return False
    prefix = f"{context}: " if context else ""
    warnings.warn(prefix + report.message(), ConvergenceWarning, stacklevel=stacklevel + 1)
    return True
