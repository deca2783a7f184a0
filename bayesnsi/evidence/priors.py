"""Proper, stated priors for the evidence of a candidate model (docs/method.md §6).

The priors are fixed before the fit and written into every report (:meth:`Priors.describe`).
A prior centred on the NSI estimate with a width taken from the fit would cancel the Occam
factor, and a superset model could then never lose; therefore:

* coefficients ``λ_i ~ N(0, s_i²)``, independent, with ``s_i`` chosen so that the term's force
  ``λ_i n_i`` is comparable to the linear restoring force at the measured amplitude
  (:func:`bayesnsi.evidence.default_coefficient_scales`), overridable per term;
* noise level ``σ_j`` log-uniform on ``[lo_j, hi_j]`` per channel (default
  ``[1e-4, 10] × std(y_j)``), i.e. ``log σ_j`` uniform;
* AR coefficients ``φ`` uniform on ``(-0.9999, 0.9999)`` each.

The evidence depends on the coefficient scale as ``log s`` per extra term (Lindley); report the
sensitivity (EVIDENCE.md: about ``log 10`` nat per decade per truly-zero coefficient).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..exceptions import InputDataError, ShapeError

__all__ = ["ARPrior", "CoefficientPrior", "NoisePrior", "Priors"]

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclass(frozen=True)
class CoefficientPrior:
    """Independent zero-mean Normal priors on the nonlinear coefficients.

    Attributes
    ----------
    names : tuple of str
        Term names, length ``q``.
    scale : ndarray, shape (q,)
        Prior standard deviations ``s_i``, in the coefficient's units (force per unit of
        ``n_i``).
    source : str
        How the scales were chosen (written into reports).
    """

    names: tuple[str, ...]
    scale: np.ndarray
    source: str = "stated by the user"

    def __post_init__(self):
        scale = np.atleast_1d(np.asarray(self.scale, dtype=float))
        names = tuple(str(n) for n in self.names)
        if scale.ndim != 1 or scale.shape[0] != len(names):
            raise ShapeError(f"coefficient prior: {len(names)} names but scale has shape {scale.shape}")
        if not np.all(np.isfinite(scale) & (scale > 0)):
            raise InputDataError(f"coefficient prior scales must be positive and finite, got {scale}")
        object.__setattr__(self, "scale", scale)
        object.__setattr__(self, "names", names)

    @property
    def n_coefficients(self) -> int:
        """``q``."""
        return len(self.names)

    def log_pdf(self, lam) -> np.ndarray:
        """Log prior density of ``λ``.

        Parameters
        ----------
        lam : array_like, shape (..., q)
            Coefficients.

        Returns
        -------
        ndarray, shape (...)
        """
        z = np.asarray(lam, dtype=float) / self.scale
        return np.sum(-0.5 * z**2 - np.log(self.scale) - 0.5 * _LOG_2PI, axis=-1)

    def sample(self, size: int | tuple[int, ...] = (), rng=None) -> np.ndarray:
        """Draw coefficients from the prior.

        Parameters
        ----------
        size : int or tuple of int
            Leading shape of the draws.
        rng : int or numpy.random.Generator, optional
            As for :func:`numpy.random.default_rng`.

        Returns
        -------
        ndarray, shape ``size + (q,)``
        """
        rng = np.random.default_rng(rng)
        shape = (size,) if isinstance(size, (int, np.integer)) else tuple(size)
        return rng.normal(0.0, 1.0, shape + (self.n_coefficients,)) * self.scale

    def with_scales(self, overrides: Mapping[str, float]) -> CoefficientPrior:
        """A copy with the scales of the named terms replaced (user override per term).

        Parameters
        ----------
        overrides : mapping of str to float
            Prior standard deviation per term name.

        Returns
        -------
        CoefficientPrior
        """
        scale = self.scale.copy()
        for name, value in overrides.items():
            if name not in self.names:
                raise InputDataError(f"no term named {name!r} in the prior; terms are {list(self.names)}")
            scale[self.names.index(name)] = float(value)
        return replace(self, scale=scale, source=f"{self.source}; overridden for {sorted(overrides)}")

    def describe(self) -> str:
        """Describe the prior, one line per term: ``name ~ N(0, s²)``.

        Returns
        -------
        str
        """
        lines = [f"coefficients: independent zero-mean Normal ({self.source})"]
        lines += [f"  {n} ~ N(0, {s:.4g}^2)" for n, s in zip(self.names, self.scale)]
        return "\n".join(lines)


@dataclass(frozen=True)
class NoisePrior:
    """Log-uniform prior on the noise (innovation) standard deviation of each channel.

    Attributes
    ----------
    lower, upper : ndarray, shape (l,)
        Bounds of ``σ_j``, in the output's units; ``log σ_j`` is uniform on
        ``[log lower_j, log upper_j]``.
    channel_names : tuple of str
        Length ``l``.
    source : str
        How the bounds were chosen.
    """

    lower: np.ndarray
    upper: np.ndarray
    channel_names: tuple[str, ...] = ()
    source: str = "stated by the user"

    def __post_init__(self):
        lo = np.atleast_1d(np.asarray(self.lower, dtype=float))
        hi = np.atleast_1d(np.asarray(self.upper, dtype=float))
        lo, hi = np.broadcast_arrays(lo, hi)
        if lo.ndim != 1:
            raise ShapeError(f"noise prior bounds must be 1-D (one per channel), found shape {lo.shape}")
        if not np.all(np.isfinite(lo) & np.isfinite(hi) & (lo > 0) & (hi > lo)):
            raise InputDataError(f"noise prior needs 0 < lower < upper < inf per channel, got {lo} and {hi}")
        names = tuple(str(n) for n in self.channel_names) or tuple(f"y{j}" for j in range(lo.size))
        if len(names) != lo.size:
            raise ShapeError(f"noise prior: {lo.size} channels but {len(names)} channel names")
        object.__setattr__(self, "lower", lo.copy())
        object.__setattr__(self, "upper", hi.copy())
        object.__setattr__(self, "channel_names", names)

    @classmethod
    def from_std(
        cls, measured_std, lower_factor: float | np.ndarray = 1e-4, upper_factor: float = 10.0, channel_names=(),
    ):
        """Default range ``[lower_factor, upper_factor] × std(y_j)`` (docs/method.md §6).

        Parameters
        ----------
        measured_std : array_like, shape (l,)
            Standard deviation of each measured channel.
        lower_factor, upper_factor : float (or array_like per channel for the lower one)
            Multipliers of ``std(y_j)`` (defaults 1e-4 and 10).
        channel_names : sequence of str, optional
        """
        std = np.atleast_1d(np.asarray(measured_std, dtype=float))
        if not np.all(std > 0):
            raise InputDataError(f"measured channels must vary (std > 0) to set a noise prior, got std = {std}")
        return cls(
            lower=lower_factor * std,
            upper=upper_factor * std,
            channel_names=tuple(channel_names),
            source=f"[{float(np.min(lower_factor)):.3g}, {upper_factor:g}] x std(measured channel)",
        )

    @property
    def n_channels(self) -> int:
        """``l``."""
        return int(self.lower.size)

    @property
    def log_width(self) -> np.ndarray:
        """``log(upper/lower)`` per channel."""
        return np.log(self.upper / self.lower)

    def log_pdf_log_sigma(self, log_sigma) -> np.ndarray:
        """Log density of ``u = log σ`` (uniform), summed over channels.

        Parameters
        ----------
        log_sigma : array_like, shape (..., l)
            ``log σ`` per channel.

        Returns
        -------
        ndarray, shape (...)
        """
        u = np.asarray(log_sigma, dtype=float)
        inside = np.all((u >= np.log(self.lower)) & (u <= np.log(self.upper)), axis=-1)
        return np.where(inside, -np.sum(np.log(self.log_width)), -np.inf)

    def log_pdf(self, sigma) -> np.ndarray:
        """Log density of ``σ`` itself (``1/(σ log(hi/lo))``), summed over channels.

        Parameters
        ----------
        sigma : array_like, shape (..., l)
            Noise standard deviation per channel.

        Returns
        -------
        ndarray, shape (...)
        """
        sigma = np.asarray(sigma, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.log(sigma)
        return self.log_pdf_log_sigma(u) - np.sum(np.where(np.isfinite(u), u, 0.0), axis=-1)

    def sample(self, size: int | tuple[int, ...] = (), rng=None) -> np.ndarray:
        """Draw noise standard deviations ``σ`` (log-uniform) from the prior.

        Parameters
        ----------
        size, rng
            As in :meth:`CoefficientPrior.sample`.

        Returns
        -------
        ndarray, shape ``size + (l,)``
        """
        rng = np.random.default_rng(rng)
        shape = (size,) if isinstance(size, (int, np.integer)) else tuple(size)
        u = rng.uniform(np.log(self.lower), np.log(self.upper), shape + (self.n_channels,))
        return np.exp(u)

    def describe(self) -> str:
        """Describe the prior, one line per channel.

        Returns
        -------
        str
        """
        lines = [f"noise sigma: log-uniform per channel ({self.source})"]
        lines += [f"  {n}: [{a:.4g}, {b:.4g}]" for n, a, b in zip(self.channel_names, self.lower, self.upper)]
        return "\n".join(lines)


@dataclass(frozen=True)
class ARPrior:
    """Uniform prior on each AR coefficient of the residual model.

    Attributes
    ----------
    lower, upper : float
        Bounds of each ``φ`` (default ``(-0.9999, 0.9999)``).
    """

    lower: float = -0.9999
    upper: float = 0.9999

    def __post_init__(self):
        if not (-1.0 <= self.lower < self.upper <= 1.0):
            raise InputDataError(f"AR prior needs -1 <= lower < upper <= 1, got ({self.lower}, {self.upper})")

    def log_pdf(self, rho) -> np.ndarray:
        """Elementwise log density of AR coefficients (uniform).

        Parameters
        ----------
        rho : array_like
            AR coefficients.

        Returns
        -------
        ndarray, shape of ``rho``
            ``-inf`` outside the bounds.
        """
        rho = np.asarray(rho, dtype=float)
        inside = (rho > self.lower) & (rho < self.upper)
        return np.where(inside, -np.log(self.upper - self.lower), -np.inf)

    def sample(self, size: int | tuple[int, ...] = (), rng=None) -> np.ndarray:
        """Draw AR coefficients (uniform) from the prior.

        Parameters
        ----------
        size, rng
            As in :meth:`CoefficientPrior.sample` (``size`` is the whole shape here).

        Returns
        -------
        ndarray, shape ``size``
        """
        rng = np.random.default_rng(rng)
        return rng.uniform(self.lower, self.upper, size)

    def describe(self) -> str:
        """Describe the prior in one line.

        Returns
        -------
        str
        """
        return f"AR coefficients: uniform({self.lower:g}, {self.upper:g}) each, per channel"


@dataclass(frozen=True)
class Priors:
    """All priors of one candidate.

    Attributes
    ----------
    coefficients : CoefficientPrior
    noise : NoisePrior
    ar : ARPrior
        Used only with an AR residual likelihood.
    """

    coefficients: CoefficientPrior
    noise: NoisePrior
    ar: ARPrior = field(default_factory=ARPrior)

    def log_prior(self, lam, log_sigma, rho=None) -> np.ndarray:
        """Joint log prior density of ``(λ, log σ[, φ])``, vectorised over leading dimensions.

        Parameters
        ----------
        lam : array_like, shape (..., q)
        log_sigma : array_like, shape (..., l)
        rho : array_like, shape (..., l, p), optional

        Returns
        -------
        ndarray, shape (...)
            ``-inf`` outside the support.
        """
        out = self.coefficients.log_pdf(lam) + self.noise.log_pdf_log_sigma(log_sigma)
        if rho is not None:
            rho = np.asarray(rho, dtype=float)
            out = out + np.sum(self.ar.log_pdf(rho), axis=(-2, -1))
        return out

    def describe(self, include_ar: bool = True) -> str:
        """Readable statement of all priors, for reports.

        Parameters
        ----------
        include_ar : bool
            Include the AR prior (False for white noise).

        Returns
        -------
        str
        """
        parts = [self.coefficients.describe(), self.noise.describe()]
        return "\n".join(parts + [self.ar.describe()] if include_ar else parts)
