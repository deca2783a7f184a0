"""Errors and warnings raised by bayesnsi.

Every error a user can cause derives from :class:`BayesNSIError`, and also from the builtin
exception it refines (``ShapeError`` is a ``ValueError``), so callers can catch either.
Each message states what was expected, what was found and what to do.
"""

__all__ = [
    "BayesNSIError",
    "ArgumentTypeError",
    "InputDataError",
    "ShapeError",
    "ExpressionError",
    "ConfigError",
    "BlockRowsError",
    "OrderError",
    "NotIdentifiableError",
    "UnstableModelError",
    "OutputExistsError",
    "SchedulerError",
    "LoopError",
    "CandidatesFailedError",
    "BayesNSIWarning",
    "SpuriousPoleWarning",
    "ConvergenceWarning",
    "CacheWarning",
    "IntervalWarning",
    "AdequacyWarning",
    "PeriodicityWarning",
    "IntegrationWarning",
    "OrderWarning",
    "FreeBodyWarning",
]


class BayesNSIError(Exception):
    """Base class of every error that bad input or an ill-posed problem can cause."""


class ArgumentTypeError(BayesNSIError, TypeError):
    """An argument of a public function is not of the type it takes (the message names both)."""


def require(value, expected: type | tuple[type, ...], name: str, hint: str = "") -> None:
    """Raise :class:`ArgumentTypeError` unless ``value`` is an instance of ``expected``.

    Parameters
    ----------
    value : object
    expected : type or tuple of type
    name : str
        The argument's name, for the message.
    hint : str
        How to build a value of the right type.

    Raises
    ------
    ArgumentTypeError
    """
    if not isinstance(value, expected):
        names = " or ".join(t.__name__ for t in (expected if isinstance(expected, tuple) else (expected,)))
        raise ArgumentTypeError(f"{name} must be a {names}, got {type(value).__name__}" + (f"; {hint}" if hint else ""))


class InputDataError(BayesNSIError, ValueError):
    """Signals are unusable: NaN/Inf, constant channels, mismatched lengths, unknown columns."""


class ShapeError(InputDataError):
    """An array does not have the documented shape."""


class ExpressionError(BayesNSIError, ValueError):
    """A candidate term expression is outside the grammar of docs/method.md §9."""


class ConfigError(BayesNSIError, ValueError):
    """An experiment configuration (TOML) is missing a field or holds an invalid value."""


class BlockRowsError(BayesNSIError, ValueError):
    """Too few samples for the requested number of block rows."""


class OrderError(BayesNSIError, ValueError):
    """The requested model order is impossible for the Hankel matrix size."""


class NotIdentifiableError(BayesNSIError, ValueError):
    """A nonlinear coefficient cannot be separated from the measured channels (docs/method.md §4)."""


class UnstableModelError(BayesNSIError, RuntimeError):
    """An identified or simulated model is unstable, or has no physical modes."""


class OutputExistsError(BayesNSIError, FileExistsError):
    """An output directory already holds results; pass ``--force`` or choose another directory."""


class SchedulerError(BayesNSIError, RuntimeError):
    """A Dask scheduler cannot be reached, or its workers cannot run this version of bayesnsi."""


class LoopError(BayesNSIError, RuntimeError):
    """Closing the loop cannot score its starting model or any effect (the reason is in the message)."""


class CandidatesFailedError(BayesNSIError, RuntimeError):
    """Every candidate of a run failed (the message sums up each one's error)."""


class BayesNSIWarning(UserWarning):
    """Base class of bayesnsi warnings: a result was computed but deserves a second look."""


class SpuriousPoleWarning(BayesNSIWarning):
    """Identified poles were discarded as non-physical (real, or zeta outside (0, 1))."""


class ConvergenceWarning(BayesNSIWarning):
    """An MCMC run did not meet the convergence criteria (r_hat, effective sample size)."""


class CacheWarning(BayesNSIWarning):
    """A cached candidate result is unreadable or not trusted; the candidate is recomputed."""


class IntervalWarning(BayesNSIWarning):
    """Intervals could not include the uncertainty of the identified linear part (too narrow)."""


class AdequacyWarning(BayesNSIWarning):
    """The selected model fails a check of adequacy (quality index, validation, residual vs noise, orders)."""


class PeriodicityWarning(BayesNSIWarning):
    """A window of a periodic record holds a period unlike the others (transient, another realisation)."""


class OrderWarning(BayesNSIWarning):
    """``order = "auto"`` chose its order at the largest gap of the singular values, but a later gap is nearly
    as large: the data may hold modes the model lacks."""


class IntegrationWarning(BayesNSIWarning):
    """``[data] integrate`` removes motion the force drives below the band (e.g. a free body's rigid-body motion)."""


class FreeBodyWarning(BayesNSIWarning):
    """A fixed ``[nsi] virtual_stiffness`` (a spring for a free body) on a record whose structure looks grounded."""
