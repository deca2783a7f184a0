"""Model replicates: the identification repeated on the identified model driven by fresh forces.

A parametric bootstrap (``interval = "surrogate"``, and the default ``"auto"`` for a candidate with
Coulomb friction, a sign() of velocities alone, :func:`holds_coulomb_friction`; docs/method.md
§11). Each replicate drives the identified model in closed loop
(:func:`bayesnsi.nsi.closed_loop.closed_loop_response`) with a *surrogate force*: the measured
force with its Fourier phases drawn afresh, the same phase for every force channel at a
frequency, so its amplitude spectrum and the forces' cross-spectra are kept; the surrogate is
circular, and the simulation starts a decay length early on its periodic extension. The model is
driven with the inputs its identification assumed: interval means for the default input hold of a
sign() term (driven by point values instead, its own noise-free records came back with sign(v2)
about 1 % low and ζ1 6-18 % high on the loop's Coulomb case; with interval means within 0.8 % and
4 %, ``tests/uncertainty/test_surrogate_intervals.py``). Sensor noise at the data's level
(:func:`~bayesnsi.noise.noise_model`) is added, and the candidate is identified
again with the same settings, order and band. In the model's world the truth is known (the
identified coefficients and modes), so the replicates' spread is the scatter of the estimate from
experiment to experiment and their mean shift its bias, both over the force realisation as well as
the noise.

Why for Coulomb friction. For a sign() of a velocity, the errors-in-variables bias of the estimate
depends on where the record's velocity reverses: it differs from record to record, and the noise
replicates of :mod:`.perturbation` (the same force, the data's noise plus fresh noise) re-randomise
the reversals the data's own noise caused, so their shift mixes that bias with the data's own error
(docs/measurements.md, "The loop's Coulomb case"). Over fresh forces the bias's spread is part of
the scatter, which the interval then carries. Measured on the loop's Coulomb case
(``benchmarks/calibration_loop.py --cases coulomb-dof2``, 97 seeds on the truth): 95 % intervals
cover α on 93 % and sign(v2) on 94 % of the seeds (noise replicates: 85 %, 88 %), 50 % intervals
47 % and 49 %, widths 1.12 and 1.03 times the seed-to-seed scatter. A position-dependent friction
sign(v)·g(x) keeps the noise replicates (they meet the targets on the twin; docs/calibration.md).

Where it does not apply (:func:`surrogate_problem`): periodic records (a multisine's phases are the
experiment's design, and the period-to-period scatter drives the noise replicates), several
realisations, and free bodies (a random force moves the rigid-body mode without bound).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..exceptions import BayesNSIError
from ..noise import noise_model, noisy_copy
from .replicates import reidentify

__all__ = ["surrogate_forces", "surrogate_problem", "model_replicates", "holds_coulomb_friction"]

_DECAY = 1e-6  # the simulation starts where the initial state's response has decayed to this fraction


def holds_coulomb_friction(result) -> bool:
    """Whether a candidate holds a Coulomb friction term, a sign() of velocities alone (``"auto"`` then
    draws model replicates).

    Parameters
    ----------
    result : NSIResult

    Returns
    -------
    bool
    """
    return any(t.expr.is_coulomb for t in getattr(result, "terms", ()))


def surrogate_problem(result, signals) -> str | None:
    """Why model replicates cannot be drawn for this record, or None when they can.

    Parameters
    ----------
    result : NSIResult
        The identified candidate.
    signals : Signals
        Its estimation data.

    Returns
    -------
    str or None
    """
    if getattr(signals, "period", None) is not None:
        return "the record is periodic (the noise replicates draw its period-to-period scatter)"
    if getattr(signals, "realisations", 1) > 1:
        return "the record holds several realisations"
    if getattr(result, "virtual_stiffness", None):
        return "the structure is a free body (a random force moves its rigid-body mode without bound)"
    return None


def surrogate_forces(force, n_records: int, rng: np.random.Generator) -> np.ndarray:
    """Phase-randomised copies of a measured force record (module notes).

    Parameters
    ----------
    force : array_like, shape (n_samples, m)
    n_records : int
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n_samples, m, n_records)
        Each record has the amplitude spectrum of ``force`` (its mean kept), with one uniform
        random phase per frequency shared by the ``m`` channels (cross-spectra kept).
    """
    force = np.asarray(force, dtype=float)
    force = force.reshape(len(force), -1)
    n = len(force)
    spectrum = np.fft.rfft(force, axis=0)
    phases = np.exp(2j * np.pi * rng.random((spectrum.shape[0], 1, int(n_records))))
    phases[0] = 1.0
    if n % 2 == 0:
        phases[-1] = np.sign(np.cos(2 * np.pi * rng.random((1, int(n_records)))))  # the Nyquist bin stays real
    return np.fft.irfft(spectrum[:, :, None] * phases, n=n, axis=0)


def _warm_up(result, n_samples: int) -> int:
    """Data samples for the model's slowest pole to decay to ``_DECAY`` (on the model's grid)."""
    radius = float(np.max(np.abs(np.linalg.eigvals(result.free_model.A)), initial=0.0))
    if radius <= 0.0:
        return 0
    if radius >= 1.0:
        return n_samples
    return min(4 * n_samples, math.ceil(math.log(_DECAY) / math.log(radius) / result.upsample))


def _simulated_records(result, signals, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Displacements and velocities of the model on each surrogate force, at the data's samples."""
    from .._resample import upsample
    from ..nsi.closed_loop import closed_loop_response, divergence_bound
    from ..nsi.feedback import resolve_input_hold

    n, factor = forces.shape[0], result.upsample
    warm = _warm_up(result, n)
    extended = forces[np.arange(-warm, n) % n]  # the surrogate is circular: its periodic extension
    if factor > 1:
        shape = extended.shape
        extended = upsample(extended.reshape(shape[0], -1), factor).reshape(shape[0] * factor, *shape[1:])
    bound = divergence_bound(signals.displacement)
    hold = resolve_input_hold(result.options.input_hold, result.terms)
    displacement, velocity = closed_loop_response(result, extended, np.zeros(result.free_model.order), bound,
                                                  signals.n_dofs, signals.fs * factor, interval_mean=hold == "average",
                                                  stride=factor)
    return displacement[warm:], velocity[warm:]


def model_replicates(result, signals, options=None, n_replicates: int = 16, seed: int = 0):
    """Re-identify a candidate on ``n_replicates`` records of its own model driven by surrogate forces.

    Parameters
    ----------
    result : NSIResult
        The full-record identification (its model, order and band are kept).
    signals : Signals
        The estimation data it came from (:func:`surrogate_problem` must return None).
    options : NSIOptions, optional
        Its identification settings (default ``NSIOptions()``).
    n_replicates : int
        Number of replicates (at least 2).
    seed : int
        Seed of the surrogate phases and the added noise.

    Returns
    -------
    noise_std : ndarray, shape (n_outputs,)
        The estimated sensor noise std of each response channel (as
        :func:`~bayesnsi.uncertainty.replicates.noise_replicates`).
    coefficients : ndarray, shape (n_ok, q)
    frequencies, damping_ratios : ndarray, shape (n_ok, n_modes)
        Matched to the model's modes (NaN where none is within 10 % in frequency).
    failures : list of str
        One message per replicate that failed; one for all when the model diverges in closed loop.

    Raises
    ------
    ValueError
        When ``n_replicates < 2`` or the record does not allow surrogates.
    """
    from ..options import NSIOptions

    if int(n_replicates) < 2:
        raise ValueError(f"n_replicates must be at least 2, got {n_replicates!r}")
    if (problem := surrogate_problem(result, signals)) is not None:
        raise ValueError(f"model replicates need a single, non-periodic record of a grounded structure: {problem}")
    options = (options or NSIOptions()).replace(order=result.order, band_hz=tuple(result.band_hz))
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 16]))
    noise = noise_model(signals, result.lowest_frequency_hz)
    y_std = noise.std()
    forces = surrogate_forces(signals.force, int(n_replicates), rng)
    q, m = len(result.coefficients), len(result.modes)
    try:
        displacement, velocity = _simulated_records(result, signals, forces)
    except (BayesNSIError, FloatingPointError) as err:
        empty = np.zeros((0, q)), np.zeros((0, m)), np.zeros((0, m))
        return (y_std, *empty, [f"model replicates: {type(err).__name__}: {err}"])

    def records():
        for k in range(int(n_replicates)):
            clean = replace(signals, force=forces[:, :, k], displacement=displacement[:, :, k],
                            velocity=None if signals.velocity is None else velocity[:, :, k])
            yield f"model replicate {k}", noisy_copy(clean, noise.draw(rng))

    return (y_std, *reidentify(result, records(), options))
