"""Is an identified model good enough? Closed-loop errors on held-out data, residual whiteness.

- :func:`validate`: closed-loop simulation on held-out segments (docs/method.md §9 ``validation``).
- :func:`residual_whiteness`: the Ljung-Box test of the residual on the estimation data, the
  classical adequacy check of system identification: a model that explains the data leaves a
  white one-step-ahead residual; a missing or wrong nonlinear term leaves structure in it.
  :func:`whiteness_applies` says where it does not (responses integrated from accelerations).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._measured import MeasuredError, measured_error
from ..exceptions import BayesNSIError, ConfigError
from ..findings import Finding

__all__ = [
    "ADEQUACY_LEVEL", "LEVEL_MISMATCH", "VALIDATION_INIT_SAMPLES", "SegmentError", "Whiteness", "level_findings",
    "measured_errors", "open_loop_error", "residual_whiteness", "validate", "whiteness_applies", "whiteness_test",
]

ADEQUACY_LEVEL = 0.01
"""Significance level of the whiteness test: a model is flagged when some channel's p < this."""

VALIDATION_INIT_SAMPLES = 50
"""Samples at the start of each validation segment used only to estimate the initial state."""


@dataclass(frozen=True)
class SegmentError:
    """Closed-loop error of one model on one validation segment.

    Attributes
    ----------
    name : str
        Name of the segment (config ``[[validation]]``).
    rmse : float or None
        RMS error over all output channels, in the units of ``quantity``; None when the simulation failed.
    nrmse : float or None
        ``sqrt(mean_c(mean(e_c^2) / mean(y_c^2)))``; None when the simulation failed.
    rmse_per_channel : tuple of float
        RMS error of each output channel.
    error : str or None
        Why the closed-loop simulation failed (diverged, unstable), else None.
    quantity : str
        What the errors measure: the measured response (``Signals.measured``: "displacement",
        "velocity" or "acceleration"; the model's displacement differentiated as
        :func:`bayesnsi._measured.to_measured` does), or "force" for a free body (the force
        predicted from the measured motion, whose open-loop simulation drifts).
    nrmse_per_channel : tuple of float
        NRMSE of each output channel.
    displacement_rmse_per_channel : tuple of float
        RMS displacement error of each channel (the model's own output; the adequacy checks
        compare it with the displacement noise); empty for a free body.
    """

    name: str
    rmse: float | None
    nrmse: float | None
    rmse_per_channel: tuple[float, ...] = ()
    error: str | None = None
    quantity: str = "displacement"
    nrmse_per_channel: tuple[float, ...] = ()
    displacement_rmse_per_channel: tuple[float, ...] = ()

    def to_dict(self) -> dict:
        """Plain-data form, as written to results.json."""
        out: dict[str, object] = {"name": self.name, "rmse": self.rmse, "nrmse": self.nrmse, "quantity": self.quantity}
        if self.error is None:
            out["rmse_per_channel"] = list(self.rmse_per_channel)
            if self.nrmse_per_channel:
                out["nrmse_per_channel"] = list(self.nrmse_per_channel)
        else:
            out["error"] = self.error
        return out


def validate(result, segments) -> tuple[SegmentError, ...]:
    """Closed-loop simulation of ``result`` on each validation segment (docs/method.md §5, 9).

    Parameters
    ----------
    result : NSIResult
        Identified model.
    segments : iterable of (str, Signals)
        Held-out data, e.g. from :func:`bayesnsi.io.load_validation`.

    Returns
    -------
    tuple of SegmentError
        One per segment. The first :data:`VALIDATION_INIT_SAMPLES` samples fix the initial state;
        the errors are computed on the rest. A free body (:func:`bayesnsi.nsi.is_free_body`) is
        judged by the force it predicts from the measured motion instead (``quantity="force"``,
        :func:`bayesnsi.nsi.force_prediction`; the means removed from the data stay removed).
    """
    from ..nsi import force_prediction, is_free_body

    out = []
    for name, signals in segments:
        if is_free_body(result):
            try:
                fp = force_prediction(result, signals)
            except BayesNSIError as err:
                out.append(SegmentError(name, None, None, error=str(err), quantity="force"))
                continue
            out.append(SegmentError(name, fp.rmse, fp.nrmse, (fp.rmse,), quantity="force"))
            continue
        try:
            rec = result.reconstruct(signals, closed_loop=True, n_init=VALIDATION_INIT_SAMPLES)
        except BayesNSIError as err:
            out.append(SegmentError(name, None, None, error=str(err)))
            continue
        residual = rec.residual[VALIDATION_INIT_SAMPLES:]
        found = measured_error(rec.measured, rec.predicted, signals, skip=VALIDATION_INIT_SAMPLES)
        out.append(
            SegmentError(
                name, found.rmse, found.nrmse, found.rmse_per_channel, quantity=found.quantity,
                nrmse_per_channel=found.nrmse_per_channel,
                displacement_rmse_per_channel=tuple(float(v) for v in np.sqrt(np.mean(residual**2, axis=0))),
            )
        )
    return tuple(out)


LEVEL_MISMATCH = 30.0
"""Factor by which a validation segment's response level, relative to its force level, may differ from the
estimation record's before :func:`level_findings` suspects a unit (the nonlinearity of a structure tested at
another force level changes it by a few times at most)."""


def level_findings(estimation, segments) -> list[Finding]:
    """Findings for validation segments whose response level does not follow their force level.

    A validation file in other units than the estimation record (mm against m, with no units row to
    say so) scales its responses by 1000 at the same force, and every candidate then validates with
    an NRMSE near 1. Each response channel's rms over the segment's force rms, against the same ratio
    on the estimation record, beyond :data:`LEVEL_MISMATCH` either way, gives a message.

    Parameters
    ----------
    estimation : Signals
        The estimation record.
    segments : iterable of (str, Signals)
        The validation segments.

    Returns
    -------
    list of Finding
        Kind ``"validation.level"``, one per such segment (subject: the segment's name).
    """
    def levels(signals):
        force = float(np.sqrt(np.mean(np.asarray(signals.force, dtype=float) ** 2)))
        response = np.sqrt(np.mean(np.asarray(signals.displacement, dtype=float) ** 2, axis=0))
        return response / force if force > 0 else None

    reference = levels(estimation)
    out = []
    for name, signals in segments:
        level = levels(signals)
        if reference is None or level is None or level.shape != reference.shape:
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = level / reference
        odd = [(n, r) for n, r in zip(estimation.output_names, ratio) if np.isfinite(r) and r > 0
               and not 1 / LEVEL_MISMATCH <= r <= LEVEL_MISMATCH]
        if odd:
            listed = ", ".join(f"{n!r} {r:.3g}x" for n, r in odd)
            message = (
                f"validation segment {name!r}: for the same force its responses are not at the estimation record's "
                f"level ({listed} of it, force level taken into account): a different unit (mm against m?) in a "
                "file without a units row? Give both files a units row, or [data] scale, or check the columns; its "
                "validation errors compare unlike quantities"
            )
            values = {f"level_ratio[{n}]": float(r) for n, r in odd}
            out.append(Finding("validation.level", message, str(name), "warning", {**values, "limit": LEVEL_MISMATCH}))
    return out


def measured_errors(result, signals, closed_loop: bool = False) -> MeasuredError:
    """Open- or closed-loop error of ``result`` on ``signals`` in the measured quantity.

    Parameters
    ----------
    result : NSIResult
        Identified model (not a free body: its errors are force errors, see :func:`validate`).
    signals : Signals
        Estimation or held-out data; ``signals.measured`` says what the sensors measured.
    closed_loop : bool
        Closed-loop simulation (the first :data:`VALIDATION_INIT_SAMPLES` samples fix the initial
        state and are left out) instead of the open-loop reconstruction.

    Returns
    -------
    MeasuredError
        Per channel and overall, with ``quantity``.
    """
    skip = VALIDATION_INIT_SAMPLES if closed_loop else 0
    rec = result.reconstruct(signals, closed_loop=closed_loop, n_init=VALIDATION_INIT_SAMPLES if closed_loop else None)
    return measured_error(rec.measured, rec.predicted, signals, skip=skip)


def open_loop_error(result, signals) -> MeasuredError | None:
    """The open-loop reconstruction error of :func:`measured_errors`, None where it does not apply.

    Parameters
    ----------
    result : NSIResult
        Identified model.
    signals : Signals
        Its estimation data.

    Returns
    -------
    MeasuredError or None
        None for a free body (judged by its force, :func:`validate`) or a failed reconstruction.
    """
    from ..nsi import is_free_body

    if is_free_body(result):
        return None
    try:
        return measured_errors(result, signals)
    except (BayesNSIError, np.linalg.LinAlgError):
        return None


@dataclass(frozen=True)
class Whiteness:
    """Ljung-Box whiteness test of a model's residual, per output channel.

    Attributes
    ----------
    residual : str
        ``"innovations"`` (one-step-ahead predictor) or ``"reconstruction"`` (open loop).
    max_lag : int
        Autocorrelation lags tested (1 to ``max_lag``).
    statistic : tuple of float
        Ljung-Box ``Q = N (N + 2) sum_k r_k^2 / (N - k)`` of each channel.
    p_value : tuple of float
        ``P(chi2(max_lag) > Q)``: small when the residual is not white.
    fraction_outside : tuple of float
        Fraction of the lags whose autocorrelation lies outside ``±1.96 / sqrt(N)``.
    """

    residual: str
    max_lag: int
    statistic: tuple[float, ...]
    p_value: tuple[float, ...]
    fraction_outside: tuple[float, ...]

    @property
    def adequate(self) -> bool:
        """True when no channel rejects whiteness at :data:`ADEQUACY_LEVEL`."""
        return min(self.p_value) >= ADEQUACY_LEVEL

    def to_dict(self) -> dict:
        """Plain-data form, as written to results.json."""
        return {
            "residual": self.residual,
            "max_lag": self.max_lag,
            "ljung_box": list(self.statistic),
            "p_value": list(self.p_value),
            "fraction_outside": list(self.fraction_outside),
            "adequate": self.adequate,
        }


def whiteness_applies(signals) -> bool:
    """Whether a white residual is what an adequate model leaves on ``signals``.

    Not for responses integrated from measured velocities or accelerations
    (``signals.measured``): the integration colours their sensor noise (1/ω² or 1/ω⁴ in the
    band), so no model's residual is white and :func:`residual_whiteness` rejects every candidate
    (Ljung-Box p = 0 for the true joint and for the linear model of the simulated ground vibration
    test at 0.1 N, where the linear model's residual is 1.09x the period-to-period noise, and for
    the true and the wrong cubic of ``benchmarks/accelerometer_intervals.py``). There the residual
    against the integrated noise (:func:`bayesnsi.checks.adequacy.model_checks`) is the adequacy check.

    Parameters
    ----------
    signals : Signals

    Returns
    -------
    bool
        True for measured displacements (with or without measured velocities).
    """
    return getattr(signals, "measured", "displacement") == "displacement"


def residual_whiteness(result, signals, residual: str = "innovations", max_lag: int = 20) -> Whiteness:
    """Ljung-Box test of the residual of ``result`` on its estimation data.

    Parameters
    ----------
    result : NSIResult
        Identified model.
    signals : Signals
        The data it was identified from.
    residual : {"innovations", "reconstruction"}
        The one-step-ahead predictor's residual (white for an adequate model; see
        :func:`bayesnsi.nsi.predictor_reconstruction`) or the open-loop reconstruction's (coloured
        by the measurement noise the model feeds back, so a stricter test).
    max_lag : int
        Lags of the test (at least 1, fewer than the samples).

    Returns
    -------
    Whiteness

    References
    ----------
    G. M. Ljung and G. E. P. Box, "On a measure of lack of fit in time series models",
    Biometrika 65(2), 297-303, 1978.

    Examples
    --------
    >>> from bayesnsi import identify, simulate_case
    >>> case = simulate_case("two-dof", seed=0)
    >>> true_model, wrong_model = (identify(case.signals, c, case.recommended) for c in case.candidates[:2])
    >>> residual_whiteness(true_model, case.signals).adequate, residual_whiteness(wrong_model, case.signals).adequate
    (True, False)
    """
    from ..nsi import affine_reconstruction, predictor_reconstruction

    builders = {"innovations": predictor_reconstruction, "reconstruction": affine_reconstruction}
    if residual not in builders:
        raise ConfigError(f"residual {residual!r} unknown; use one of {sorted(builders)}")
    affine = builders[residual](result, signals)
    return whiteness_test(affine.measured - affine.predict(affine.estimate), residual, max_lag)


def whiteness_test(error, residual: str = "innovations", max_lag: int = 20) -> Whiteness:
    """Ljung-Box test of a residual record, per channel (what :func:`residual_whiteness` computes).

    Parameters
    ----------
    error : ndarray, shape (n_samples, n_channels)
        The residual (its mean is removed).
    residual : str
        What the residual is (``"innovations"`` or ``"reconstruction"``), kept in the result.
    max_lag : int
        Lags of the test (at least 1, fewer than the samples).

    Returns
    -------
    Whiteness
    """
    from scipy.special import chdtrc  # scipy.stats would import scipy.optimize (0.3 s) into every command

    error = np.asarray(error, dtype=float)
    error = error - error.mean(axis=0)
    n = error.shape[0]
    if isinstance(max_lag, bool) or not isinstance(max_lag, (int, np.integer)) or not 1 <= max_lag < n - 1:
        raise ConfigError(f"max_lag must be an integer from 1 to {n - 2} (the record has {n} samples), got {max_lag!r}")
    lags = np.arange(1, max_lag + 1)
    power = np.einsum("nc,nc->c", error, error)
    power = np.where(power > 0, power, 1.0)
    r = np.stack([np.einsum("nc,nc->c", error[:-k], error[k:]) for k in lags]) / power  # (max_lag, l)
    statistic = n * (n + 2) * np.sum(r**2 / (n - lags)[:, None], axis=0)
    outside = np.mean(np.abs(r) > 1.96 / np.sqrt(n), axis=0)
    return Whiteness(
        residual,
        int(max_lag),
        tuple(float(q) for q in statistic),
        tuple(float(p) for p in chdtrc(max_lag, statistic)),  # P(chi2(max_lag) > Q)
        tuple(float(f) for f in outside),
    )
