"""The result of nonlinear subspace identification and its reusable Hankel products (docs/method.md §3-4)."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from ..exceptions import ConfigError
from ..models import CandidateModel, Term
from ..options import NSIOptions
from ..signals import Signals
from .feedback import extended_input, working_signals
from .free_body import PhysicalParameters, free_frf, free_model, physical_parameters, stabilise
from .physics import CoefficientEstimate, Mode, coefficient_spectrum
from .statespace import StateSpaceModel

__all__ = ["IdentificationFit", "NSIResult"]


@dataclass(frozen=True)
class IdentificationFit:
    """What an identification measured on its data besides the model (docs/method.md §3, §11).

    Attributes
    ----------
    n_samples : int
        Samples of the record (at the data's rate).
    fs : float
        Sampling frequency of the data [Hz].
    reflected_poles_hz : tuple of float
        Unstable poles outside the band the data inform, mirrored into the stable region.
    virtual_mode_mirrored_hz : tuple of float
        A free body's virtual-spring mode mirrored into the unit circle (time route).
    fit_band_hz : (float, float) or None
        Frequency route: the lines fitted (None on the time route).
    requested_block_rows : int or None
        Frequency route: the block rows asked for (above M/(m+q+l) lines the route uses fewer, in
        ``options.block_rows``; None on the time route).
    period, n_periods, n_realisations : int
        Frequency route: samples per period, periods averaged, realisations stacked (0 on the time route).
    n_lines, n_band_lines : int
        Frequency route: excited lines fitted per realisation, and all band lines fitted.
    stable_modes_hz : tuple of float
        Frequency route with ``order = "auto"``: the modes the stabilisation diagram found stable in
        frequency, damping and shape [Hz] (empty otherwise).
    line_misfit, band_misfit : float or None
        Frequency route: noise-weighted rms misfit on the excited lines (about 1: down to the noise)
        and on every band line.
    unexcited_ratio : tuple of (str, tuple of float), or None
        Frequency route: output power over its noise at the unexcited ``("odd", ...)`` and
        ``("even", ...)`` lines per output (None with several forces or without such lines).
    """

    n_samples: int
    fs: float
    reflected_poles_hz: tuple[float, ...] = ()
    virtual_mode_mirrored_hz: tuple[float, ...] = ()
    fit_band_hz: tuple[float, float] | None = None
    requested_block_rows: int | None = None
    period: int = 0
    n_periods: int = 0
    n_realisations: int = 0
    n_lines: int = 0
    n_band_lines: int = 0
    stable_modes_hz: tuple[float, ...] = ()
    line_misfit: float | None = None
    band_misfit: float | None = None
    unexcited_ratio: tuple[tuple[str, tuple[float, ...]], ...] | None = None


@dataclass(frozen=True)
class NSIResult:
    """Result of :func:`identify` for one candidate model.

    Attributes
    ----------
    candidate : CandidateModel
    model : StateSpaceModel
        Discrete-time extended-input model in physical units (inputs [N] and term values,
        outputs [m]).
    singular_values : ndarray, shape (i·l,)
        Of the weighted oblique projection (paper Fig. 3).
    order : int
    block_rows : int
    input_dofs, output_dofs : tuple of int
    band_hz : (float, float)
        Band over which λ_i(ω) is averaged.
    modes : tuple of Mode
        Physical modes, by frequency.
    spurious_poles : ndarray of complex
        Continuous-time poles discarded as non-physical.
    coefficients : tuple of CoefficientEstimate
    options : NSIOptions
        The settings it ran with, every ``"auto"`` resolved (order, band, band mean, input hold,
        virtual stiffness): everything needed to reproduce the identification.
    fit : IdentificationFit
        What the route measured on the data (reflected poles; lines and misfits of the frequency route).
    rigid_body_poles : ndarray of complex
        Rigid-body poles (s ≈ 0) of a free body, reported as such (``options.virtual_stiffness``
        then holds the known spring the identification used, see :mod:`bayesnsi.nsi.free_body`).

    See Also
    --------
    bayesnsi.tables.modes_frame, bayesnsi.tables.coefficients_frame :
        ``modes`` and ``coefficients`` as pandas DataFrames.
    """

    candidate: CandidateModel
    model: StateSpaceModel
    singular_values: np.ndarray
    order: int
    block_rows: int
    input_dofs: tuple[int, ...]
    output_dofs: tuple[int, ...]
    band_hz: tuple[float, float]
    modes: tuple[Mode, ...]
    spurious_poles: np.ndarray
    coefficients: tuple[CoefficientEstimate, ...]
    options: NSIOptions = field(default_factory=NSIOptions)
    fit: IdentificationFit = field(default_factory=lambda: IdentificationFit(n_samples=0, fs=0.0))
    rigid_body_poles: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=complex))

    @property
    def terms(self) -> tuple[Term, ...]:
        """The candidate's nonlinear terms."""
        return self.candidate.terms

    @property
    def coefficient_values(self) -> np.ndarray:
        """Estimated λ_i (mean Re λ_i(ω) over the band), shape (q,)."""
        return np.array([c.value for c in self.coefficients])

    @property
    def lowest_frequency_hz(self) -> float:
        """Lowest natural frequency of the identified modes [Hz] (0 without modes)."""
        return min((m.frequency_hz for m in self.modes), default=0.0)

    @property
    def settings(self) -> dict[str, Any]:
        """The options and the fit as one JSON-ready record (results.json ``settings`` of a candidate).

        Returns
        -------
        dict
        """
        record = {**self.options.to_dict(), "n_samples": self.fit.n_samples, "fs": self.fit.fs}
        for item in fields(self.fit):
            value = getattr(self.fit, item.name)
            if item.name in ("n_samples", "fs") or (self.options.domain != "frequency" and item.name not in (
                    "reflected_poles_hz", "virtual_mode_mirrored_hz")):
                continue
            if item.name == "unexcited_ratio":
                value = None if value is None else {k: list(v) for k, v in value}
            record[item.name] = list(value) if isinstance(value, tuple) else value
        return record

    @property
    def virtual_stiffness(self) -> float:
        """Known spring [N/m] on the input during identification (0: none; free bodies)."""
        stiffness = self.options.virtual_stiffness
        return 0.0 if isinstance(stiffness, str) else float(stiffness)

    @property
    def free_model(self) -> StateSpaceModel:
        """The identified model driven by the measured forces (any virtual spring removed)."""
        return free_model(self.model, self.virtual_stiffness, self.input_dofs, self.output_dofs)

    @property
    def physical_parameters(self) -> tuple[PhysicalParameters, ...]:
        """Mass, viscous damping and stiffness of a one-DOF model from its FRF (else empty)."""
        return physical_parameters(self)

    def frf(self, freqs_hz) -> np.ndarray:
        """Extended FRF H_E(ω) of the identified model (docs/method.md §4; free body: spring removed).

        Parameters
        ----------
        freqs_hz : array_like, shape (n_freq,)
            Frequencies [Hz].

        Returns
        -------
        ndarray of complex, shape (n_freq, l, m + q)
        """
        return free_frf(self.model.frf(freqs_hz), self.virtual_stiffness, self.input_dofs, self.output_dofs)

    def underlying_frf(self, freqs_hz) -> np.ndarray:
        """Underlying linear FRF H(ω)[O, P]: the force columns of the extended FRF.

        Parameters
        ----------
        freqs_hz : array_like, shape (n_freq,)
            Frequencies [Hz].

        Returns
        -------
        ndarray of complex, shape (n_freq, l, m)
        """
        return self.frf(freqs_hz)[:, :, : len(self.input_dofs)]

    def to_statespace(self, output: int | str | None = None, force: int | str | None = None):
        """The underlying linear model as a :class:`scipy.signal.StateSpace` (discrete time).

        ``StateSpace(A, B[:, :m], C, D[:, :m], dt)``: the force columns of the identified
        extended-input model, so its frequency response is :meth:`underlying_frf` exactly. ``dt``
        is the model's sampling interval (the data's, or the upsampled grid's, see
        :attr:`upsample`); inputs are the forces, outputs the displacements, in the data's units;
        a free body's virtual spring is removed (:attr:`free_model`). One force/response pair is
        picked by ``output`` and ``force``, as scipy's single-input frequency-response functions
        (``scipy.signal.dfreqresp``, ``dbode``) need. For python-control (``pip install control``):
        ``control.ss(s.A, s.B, s.C, s.D, s.dt)`` with ``s = result.to_statespace()``.

        Parameters
        ----------
        output : int or str, optional
            The response: its DOF (int) or its name ``"x<dof>"``; all responses when None.
        force : int or str, optional
            The force: the DOF it acts at (int) or its name ``"f<dof>"``; all forces when None.

        Returns
        -------
        scipy.signal.StateSpace

        Raises
        ------
        ConfigError
            When ``output`` or ``force`` names no channel of the model.
        """
        from scipy.signal import StateSpace

        m = len(self.input_dofs)
        model = self.free_model  # a free body's virtual spring removed (the same model otherwise)
        rows = self._channel(output, self.output_dofs, "x", "output")
        columns = self._channel(force, self.input_dofs, "f", "force")
        return StateSpace(model.A, model.B[:, :m][:, columns], model.C[rows, :], model.D[:, :m][rows][:, columns],
                          dt=model.dt)

    @staticmethod
    def _channel(which, dofs, prefix: str, role: str) -> slice | list[int]:
        """Columns (or rows) of one channel named by DOF or ``"<prefix><dof>"``; all of them for None."""
        if which is None:
            return slice(None)
        dof = int(which[len(prefix):]) if isinstance(which, str) and which[len(prefix):].isdigit() else which
        if isinstance(dof, bool) or dof not in dofs:
            raise ConfigError(f"{role} {which!r} is not a channel of the model; choose one of "
                              f"{[f'{prefix}{d}' for d in dofs]}")
        return [list(dofs).index(dof)]

    def innovation_form(self, signals: Signals, noise_std=None, force_noise_std=None):
        """The model's innovation form: its steady-state Kalman gain for the noise of ``signals``.

        ``x̂_{k+1} = A x̂_k + B u_k + K ε_k``, ``y_k = C x̂_k + D u_k + ε_k`` with white
        innovations ε; K solves the Riccati equation for the measurement noise of the outputs
        (estimated from ``signals`` unless given), the process noise that noisy nonlinear inputs
        carry, and an optional unmeasured white force at the input DOFs
        (:mod:`bayesnsi.nsi.innovation`).

        Parameters
        ----------
        signals : Signals
            The data the noise levels are taken from.
        noise_std : array_like, shape (l,), optional
            Measurement-noise std of each displacement channel.
        force_noise_std : array_like, shape (m,), optional
            Std of an unmeasured white force at each input DOF (default: none).

        Returns
        -------
        InnovationForm
            ``.gain`` (K), ``.innovation_covariance``, ``.predictor``, ``.innovations(u, y)``.

        Examples
        --------
        >>> form = result.innovation_form(signals)  # doctest: +SKIP
        >>> eps = form.innovations(result.extended_input(signals), signals.displacement)  # doctest: +SKIP
        """
        from .innovation import innovation_form

        return innovation_form(self, signals, noise_std, force_noise_std)

    def kalman_gain(self, signals: Signals, noise_std=None, force_noise_std=None) -> np.ndarray:
        """The steady-state Kalman gain K, shape (n, l), of :meth:`innovation_form`.

        Parameters
        ----------
        signals, noise_std, force_noise_std
            As in :meth:`innovation_form`.

        Returns
        -------
        ndarray, shape (n, l)
        """
        return self.innovation_form(signals, noise_std, force_noise_std).gain

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(
            self, candidate=self.candidate.name, order=self.order, block_rows=self.block_rows,
            input_dofs=self.input_dofs, output_dofs=self.output_dofs,
            frequencies_hz=tuple(round(m.frequency_hz, 4) for m in self.modes),
            coefficients={c.term.name: float(f"{c.value:.5g}") for c in self.coefficients},
        )

    def coefficient_spectrum(self, freqs_hz) -> np.ndarray:
        """Frequency-dependent coefficients λ_i(ω) from the extended FRF (paper Eqs. 24-32).

        Parameters
        ----------
        freqs_hz : array_like, shape (n_freq,)
            Frequencies [Hz].

        Returns
        -------
        ndarray of complex, shape (n_freq, q)
        """
        return coefficient_spectrum(self.frf(freqs_hz), self.input_dofs, self.output_dofs, self.terms)

    @property
    def upsample(self) -> int:
        """Factor between the identification grid and the data's sampling (1: the same)."""
        return int(self.options.upsample)

    def working_signals(self, signals: Signals) -> Signals:
        """The signals on the identification grid (band-limited interpolation when upsampled).

        Parameters
        ----------
        signals : Signals
            At the data's rate.

        Returns
        -------
        Signals
            With the known spring moved to the input (``f + k·x``) for a free body.
        """
        return stabilise(working_signals(signals, self.upsample), self.virtual_stiffness)

    def extended_input(self, signals: Signals, on_grid: bool = False) -> np.ndarray:
        """Extended input of this candidate on the model's grid.

        Parameters
        ----------
        signals : Signals
            At the data's rate, or already on the model's grid (``on_grid=True``, e.g. from
            :meth:`working_signals`, which saves interpolating them again).
        on_grid : bool
            Whether ``signals`` are already on the model's grid.

        Returns
        -------
        ndarray, shape (n_samples, m + q)
            See :func:`bayesnsi.nsi.extended_input`.
        """
        return extended_input(
            signals if on_grid else self.working_signals(signals),
            self.terms,
            self.options.velocity_method,
            self.options.input_hold,
        )

    def reconstruct(self, signals: Signals, closed_loop: bool = False, n_init: int | None = None):
        """Open- or closed-loop reconstruction of ``signals`` by this model.

        Parameters
        ----------
        signals : Signals
            Data to reconstruct.
        closed_loop : bool
            Nonlinear inputs from the model's own response instead of the measured one.
        n_init : int, optional
            Samples used for the initial state.

        Returns
        -------
        Reconstruction
            See :func:`bayesnsi.nsi.reconstruct`.
        """
        from .reconstruct import reconstruct

        return reconstruct(self, signals, closed_loop=closed_loop, n_init=n_init)
