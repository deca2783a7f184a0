"""Proper, stated priors for the evidence of a candidate model (SPEC section 6).

The priors are fixed before the fit and written into every report (:meth:`Priors.describe`).
A prior centred on the NSI estimate with a width taken from the fit would cancel the Occam
factor, and a superset model could then never lose; therefore:

* coefficients ``λ_i ~ N(0, s_i²)``, independent, with ``s_i`` chosen so that the term's force
  ``λ_i n_i`` is comparable to the linear restoring force at the measured amplitude
  (:func:`default_coefficient_scales`), overridable per term;
* noise level ``σ_j`` log-uniform on ``[lo_j, hi_j]`` per channel (default
  ``[1e-4, 10] × std(y_j)``), i.e. ``log σ_j`` uniform;
* AR coefficients ``φ`` uniform on ``(-0.9999, 0.9999)`` each.

The evidence depends on the coefficient scale as ``log s`` per extra term (Lindley); report the
sensitivity (EVIDENCE.md: about ``log 10`` nat per decade per truly-zero coefficient).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..exceptions import InputDataError, ShapeError

__all__ = [
    "CoefficientPrior",
    "NoisePrior",
    "ARPrior",
    "Priors",
    "default_coefficient_scales",
    "coefficient_prior",
    "default_priors",
]

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
        """Log prior density of ``λ``, shape (...) for ``lam`` of shape (..., q)."""
        z = np.asarray(lam, dtype=float) / self.scale
        return np.sum(-0.5 * z**2 - np.log(self.scale) - 0.5 * _LOG_2PI, axis=-1)

    def sample(self, size: int | tuple = (), rng=None) -> np.ndarray:
        """Prior draws, shape ``size + (q,)``; ``rng`` as for :func:`numpy.random.default_rng`."""
        rng = np.random.default_rng(rng)
        size = (size,) if np.isscalar(size) else tuple(size)
        return rng.normal(0.0, 1.0, size + (self.n_coefficients,)) * self.scale

    def with_scales(self, overrides: Mapping[str, float]) -> CoefficientPrior:
        """A copy with the scales of the named terms replaced (user override per term)."""
        scale = self.scale.copy()
        for name, value in overrides.items():
            if name not in self.names:
                raise InputDataError(f"no term named {name!r} in the prior; terms are {list(self.names)}")
            scale[self.names.index(name)] = float(value)
        return replace(self, scale=scale, source=f"{self.source}; overridden for {sorted(overrides)}")

    def describe(self) -> str:
        """One line per term: ``name ~ N(0, s²)``."""
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
    def from_std(cls, measured_std, lower_factor: float = 1e-4, upper_factor: float = 10.0, channel_names=()):
        """Default range ``[lower_factor, upper_factor] × std(y_j)`` (SPEC 6).

        Parameters
        ----------
        measured_std : array_like, shape (l,)
            Standard deviation of each measured channel.
        lower_factor, upper_factor : float
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
            source=f"[{lower_factor:g}, {upper_factor:g}] x std(measured channel)",
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
        """Log density of ``u = log σ`` (uniform), summed over channels; shape (...)."""
        u = np.asarray(log_sigma, dtype=float)
        inside = np.all((u >= np.log(self.lower)) & (u <= np.log(self.upper)), axis=-1)
        return np.where(inside, -np.sum(np.log(self.log_width)), -np.inf)

    def log_pdf(self, sigma) -> np.ndarray:
        """Log density of ``σ`` itself (``1/(σ log(hi/lo))``), summed over channels."""
        sigma = np.asarray(sigma, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.log(sigma)
        return self.log_pdf_log_sigma(u) - np.sum(np.where(np.isfinite(u), u, 0.0), axis=-1)

    def sample(self, size: int | tuple = (), rng=None) -> np.ndarray:
        """Prior draws of ``σ``, shape ``size + (l,)``."""
        rng = np.random.default_rng(rng)
        size = (size,) if np.isscalar(size) else tuple(size)
        u = rng.uniform(np.log(self.lower), np.log(self.upper), size + (self.n_channels,))
        return np.exp(u)

    def describe(self) -> str:
        """One line per channel."""
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
        """Elementwise log density of AR coefficients (uniform); ``-inf`` outside the bounds."""
        rho = np.asarray(rho, dtype=float)
        inside = (rho > self.lower) & (rho < self.upper)
        return np.where(inside, -np.log(self.upper - self.lower), -np.inf)

    def sample(self, size: int | tuple = (), rng=None) -> np.ndarray:
        """Prior draws of shape ``size``."""
        rng = np.random.default_rng(rng)
        return rng.uniform(self.lower, self.upper, size)

    def describe(self) -> str:
        """One line."""
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
        """Readable statement of all priors, for reports (``include_ar=False`` for white noise)."""
        parts = [self.coefficients.describe(), self.noise.describe()]
        return "\n".join(parts + [self.ar.describe()] if include_ar else parts)


def default_coefficient_scales(term_rms, reference_force_rms) -> np.ndarray:
    """Default prior scales ``s_i = F_ref / rms(n_i)`` (SPEC 6).

    With this scale a coefficient one standard deviation from zero makes the term's force
    ``λ_i n_i(x, ẋ)`` as large (in RMS) as the reference force, typically the linear restoring
    force at the measured amplitude, e.g. ``k · rms(x)`` at the term's location.

    Parameters
    ----------
    term_rms : array_like, shape (q,)
        RMS of each nonlinear function ``n_i`` evaluated on the measured data (the extended
        input columns), in its own units.
    reference_force_rms : float or array_like, shape (q,)
        Reference force RMS [N], one for all terms or one per term.

    Returns
    -------
    ndarray, shape (q,)
    """
    term_rms = np.atleast_1d(np.asarray(term_rms, dtype=float))
    ref = np.broadcast_to(np.asarray(reference_force_rms, dtype=float), term_rms.shape)
    if not np.all(np.isfinite(term_rms) & (term_rms > 0)):
        raise InputDataError(f"term RMS values must be positive and finite, got {term_rms}")
    if not np.all(np.isfinite(ref) & (ref > 0)):
        raise InputDataError(f"reference force RMS must be positive and finite, got {ref}")
    return ref / term_rms


def coefficient_prior(
    names: Sequence[str], term_rms, reference_force_rms, overrides: Mapping[str, float] | None = None
) -> CoefficientPrior:
    """Default coefficient prior with optional per-term overrides.

    Parameters
    ----------
    names : sequence of str
        Term names, length ``q``.
    term_rms, reference_force_rms
        See :func:`default_coefficient_scales`.
    overrides : mapping of str to float, optional
        Prior scales set by the user for some terms.

    Returns
    -------
    CoefficientPrior
    """
    scale = default_coefficient_scales(term_rms, reference_force_rms)
    ref = np.atleast_1d(np.asarray(reference_force_rms, dtype=float))
    ref_text = f"{ref[0]:.4g}" if ref.size == 1 else "per term"
    prior = CoefficientPrior(
        names=tuple(names),
        scale=scale,
        source=f"scale = reference force RMS ({ref_text}) / rms(n_i)",
    )
    return prior.with_scales(overrides) if overrides else prior


def default_priors(
    affine,
    term_rms,
    reference_force_rms,
    overrides: Mapping[str, float] | None = None,
    channel_names: Sequence[str] = (),
    noise_factors: tuple[float, float] = (1e-4, 10.0),
    ar_bounds: tuple[float, float] = (-0.9999, 0.9999),
) -> Priors:
    """The default priors of SPEC 6 for an affine reconstruction.

    Parameters
    ----------
    affine : AffineReconstruction
        Supplies the term names and ``std`` of the measured channels.
    term_rms, reference_force_rms
        See :func:`default_coefficient_scales`.
    overrides : mapping of str to float, optional
        Per-term coefficient prior scales.
    channel_names : sequence of str, optional
    noise_factors : (float, float)
        ``σ_j`` range as multiples of ``std(y_j)``.
    ar_bounds : (float, float)
        Bounds of each AR coefficient.

    Returns
    -------
    Priors
    """
    measured = np.asarray(affine.measured, dtype=float)
    std = measured.reshape(len(measured), -1).std(axis=0)
    return Priors(
        coefficients=coefficient_prior(affine.names, term_rms, reference_force_rms, overrides),
        noise=NoisePrior.from_std(std, *noise_factors, channel_names=channel_names),
        ar=ARPrior(*ar_bounds),
    )
