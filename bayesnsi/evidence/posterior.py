"""A posterior's draws and the sampler that drew them (docs/method.md §6).

:class:`PosteriorSamples` holds the draws of :func:`bayesnsi.evidence.sampling.sample_posterior`
(``(chain, draw, ...)``, one chain per walker) and turns them into an arviz ``DataTree``;
:class:`SamplerRecord` says which sampler really ran, with which moves and for how long.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["PosteriorSamples", "SamplerRecord"]


@dataclass(frozen=True)
class SamplerRecord:
    """What drew a posterior: the sampler that really ran, its moves and run length (docs/method.md §6).

    Attributes
    ----------
    name : str
        ``"emcee"``, or ``"exact draws"`` when nothing was left to sample (a linear candidate with the
        noise parameters integrated out: they are drawn independently from their posterior).
    version : str
        The sampler's version (emcee's; the package's for exact draws).
    moves : tuple of str
        emcee's moves.
    weights : tuple of float
        Their probabilities per step.
    n_walkers : int
        Walkers (= chains).
    n_steps : int
        Steps run per walker, burn-in included.
    n_burn : int
        Steps discarded at the start.
    parameters : str
        What was sampled: ``"coefficients (noise parameters integrated out)"`` or ``"all parameters"``.
    """

    name: str
    version: str
    moves: tuple[str, ...]
    weights: tuple[float, ...]
    n_walkers: int
    n_steps: int
    n_burn: int
    parameters: str

    def describe(self) -> str:
        """One line, e.g. ``"emcee 3.1.6: independence 0.8, ...; 32 walkers x 450 steps (50 burn-in); ..."``.

        Returns
        -------
        str
        """
        if self.name != "emcee":
            return f"{self.name}; {self.parameters}"
        moves = ", ".join(f"{name} {weight:g}" for name, weight in zip(self.moves, self.weights))
        return (f"emcee {self.version}: {moves}; {self.n_walkers} walkers x {self.n_steps} steps "
                f"({self.n_burn} burn-in); {self.parameters}")

    def to_dict(self) -> dict:
        """JSON-ready fields.

        Returns
        -------
        dict
        """
        return {"name": self.name, "version": self.version,
                "moves": [{"move": name, "weight": weight} for name, weight in zip(self.moves, self.weights)],
                "n_walkers": self.n_walkers, "n_steps": self.n_steps, "n_burn": self.n_burn,
                "parameters": self.parameters, "description": self.describe()}


@dataclass(frozen=True)
class PosteriorSamples:
    """emcee draws after burn-in, with what is needed to read them.

    Attributes
    ----------
    samples : ndarray, shape (chain, draw, n_params)
        ``θ = (λ_1..λ_q, log σ_1..log σ_l, φ_{1,1}..φ_{l,p})``; one chain per walker.
    log_posterior : ndarray, shape (chain, draw)
        Unnormalised log posterior of each draw.
    param_names : tuple of str
        Names of the ``n_params`` columns.
    coefficient_names : tuple of str
        Length ``q``.
    channel_names : tuple of str
        Length ``l``.
    likelihood : str
        ``"white"``, ``"ar1"`` (exact stationary AR(1)) or ``"arP"`` (conditional AR(P)).
    ar_order : int
        ``p`` (0 for white noise).
    acceptance_fraction : ndarray, shape (chain,)
        emcee acceptance fraction per walker.
    autocorr_time : ndarray, shape (n_params,)
        emcee's integrated autocorrelation time estimate [steps].
    autocorr_reliable : bool
        False when the run is shorter than 50 autocorrelation times (emcee's criterion); the
        estimate is then a lower bound.
    mode : ndarray, shape (n_params,)
        Posterior mode found by Newton's method (where the walkers were started).
    mode_covariance : ndarray, shape (n_params, n_params)
        Inverse negative Hessian at the mode (Laplace covariance).
    settings : mapping
        ``n_walkers``, ``n_steps``, ``n_burn``, ``seed`` (of emcee's generator), versions, ``sampler``
        (:meth:`SamplerRecord.describe`).
    sampler : SamplerRecord, optional
        The sampler that drew these samples.
    """

    samples: np.ndarray
    log_posterior: np.ndarray
    param_names: tuple[str, ...]
    coefficient_names: tuple[str, ...]
    channel_names: tuple[str, ...]
    likelihood: str
    ar_order: int
    acceptance_fraction: np.ndarray
    autocorr_time: np.ndarray
    autocorr_reliable: bool
    mode: np.ndarray
    mode_covariance: np.ndarray
    settings: Mapping = field(default_factory=dict)
    sampler: SamplerRecord | None = None

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(
            self, likelihood=self.likelihood, coefficient_names=self.coefficient_names,
            channel_names=self.channel_names, samples=self.samples,
        )

    @property
    def n_coefficients(self) -> int:
        """``q``."""
        return len(self.coefficient_names)

    @property
    def n_channels(self) -> int:
        """``l``."""
        return len(self.channel_names)

    @property
    def coefficients(self) -> np.ndarray:
        """``λ`` draws, shape (chain, draw, q)."""
        return self.samples[..., : self.n_coefficients]

    @property
    def sigma(self) -> np.ndarray:
        """``σ`` draws, shape (chain, draw, l), in the output's units."""
        q, l = self.n_coefficients, self.n_channels
        return np.exp(self.samples[..., q : q + l])

    @property
    def rho(self) -> np.ndarray | None:
        """AR coefficient draws, shape (chain, draw, l, p), or None for white noise."""
        if not self.ar_order:
            return None
        q, l = self.n_coefficients, self.n_channels
        return self.samples[..., q + l :].reshape(self.samples.shape[:2] + (l, self.ar_order))

    def to_datatree(self):
        """The draws as an arviz ``DataTree`` (arviz_base), dims ``(chain, draw, ...)``.

        Returns
        -------
        xarray.DataTree
            Group ``posterior`` with ``coefficient`` (chain, draw, term; absent when q = 0),
            ``sigma`` (chain, draw, channel) and, for AR likelihoods, ``rho`` (chain, draw, channel[, lag]);
            group ``sample_stats`` with ``lp`` (chain, draw).

        Notes
        -----
        Built with ``arviz_base.from_dict`` and explicit ``sample_dims=["chain", "draw"]`` rather
        than ``from_emcee``, whose dimension order differs between arviz versions
        (EVIDENCE.md); the order is checked after conversion.
        """
        from arviz_base import from_dict

        posterior = {"sigma": self.sigma}
        dims = {"sigma": ["channel"]}
        coords = {"channel": list(self.channel_names)}
        if self.n_coefficients:  # a linear-only candidate has no coefficient variable
            posterior = {"coefficient": self.coefficients, **posterior}
            dims["coefficient"] = ["term"]
            coords["term"] = list(self.coefficient_names)
        if self.ar_order == 1:
            posterior["rho"] = self.rho[..., 0]
            dims["rho"] = ["channel"]
        elif self.ar_order > 1:
            posterior["rho"] = self.rho
            dims["rho"] = ["channel", "lag"]
            coords["lag"] = list(range(1, self.ar_order + 1))
        sampler = self.sampler.describe() if self.sampler is not None else str(self.settings.get("sampler", ""))
        attrs = {
            "posterior": {
                "likelihood": self.likelihood,
                "sampler": sampler,
                "n_burn": int(self.settings.get("n_burn", 0)),
            }
        }
        tree = from_dict(
            {"posterior": posterior, "sample_stats": {"lp": self.log_posterior}},
            sample_dims=["chain", "draw"],
            coords=coords,
            dims=dims,
            attrs=attrs,
        )
        for name, var in tree["posterior"].data_vars.items():
            if tuple(var.dims[:2]) != ("chain", "draw"):  # pragma: no cover - guards an API change
                raise RuntimeError(f"arviz stored {name} with dims {var.dims}; expected (chain, draw, ...)")
        return tree
