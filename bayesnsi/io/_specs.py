"""The validated configuration objects that :func:`bayesnsi.io.load_config` returns."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..models import CandidateModel
from ..options import EvidenceOptions, LoopOptions, NSIOptions

__all__ = ["DataSpec", "IntegrationSpec", "ValidationSegment", "ExperimentConfig"]


@dataclass(frozen=True)
class IntegrationSpec:
    """How displacements and velocities are derived from accelerations (``[data] integrate``).

    Written as an inline table, e.g. ``integrate = { band_hz = [1.0, 40.0] }``; only
    ``band_hz`` is required. The arguments are those of
    :func:`bayesnsi.preprocess.integrate_acceleration`, whose docstring states the gain and
    phase of each method and its limits.

    Parameters
    ----------
    band_hz : (float, float)
        ``[f_lo, f_hi]`` [Hz], ``0 < f_lo < f_hi``: everything below ``f_lo`` is removed (drift
        and true motion alike); ``f_hi`` is a low-pass, none when ``f_hi >= fs/2``. Put ``f_lo``
        below the lowest mode (a factor 2 or more) and ``[nsi] band_hz`` inside this band.
    method : {"frequency", "time"}
        Frequency-domain division by jω, (jω)² with a zero-phase raised-cosine band window
        (default), or trapezoid rule + polynomial detrend + zero-phase Butterworth high-pass.
    taper : float
        Relative width of the raised-cosine transitions (frequency method), in [0, 1).
    filter_inputs : bool
        Filter the forces with the same band weighting (:func:`bayesnsi.preprocess.band_filter`),
        so that input and output carry one filter (default true). Without it the outputs miss
        the content below ``f_lo`` that the forces still have: on the two-DOF case this made
        the identification fail.
    filter_order : int
        Butterworth order (time method).
    detrend_order : int
        Polynomial order removed after each integration (time method).
    noise_std : float or None
        Declared white noise std of every accelerometer, in the file's acceleration unit (before
        ``[data] scale``), e.g. from the sensor's data sheet; None (default): estimated from the
        accelerations before integration (:mod:`bayesnsi.noise.accelerometer`). On a record without
        whole periods the noise replicates and the adequacy check integrate it by this recipe.
    trim_edges : bool
        Drop ``2 / (taper f_lo)`` seconds at each end of every window after integrating (and
        decimating) it, not on whole periods (default true): there the integrated motion misses the
        acceleration outside the window (taken as zero), an error that biases the identification and
        the evidence and that no noise replicate carries (clean cubic chain, 60 s, band 1-45 Hz: k3
        off by -4.2 to +3.5 % with the edges, within 0.2 % without;
        ``benchmarks/accelerometer_intervals.py``). A window shorter than four times that is kept
        whole with an IntegrationWarning. False keeps every sample of the window.
    """

    band_hz: tuple[float, float]
    method: str = "frequency"
    taper: float = 0.5
    filter_inputs: bool = True
    filter_order: int = 4
    detrend_order: int = 2
    noise_std: float | None = None
    trim_edges: bool = True


@dataclass(frozen=True)
class DataSpec:
    """Where the measurements are and which column is what (``[data]``).

    The file format follows the extension of ``file``: ``.mat`` (MATLAB v5 via scipy, v7.3
    via h5py), ``.h5``/``.hdf5``, ``.uff``/``.unv`` (Universal File Format dataset 58, via
    pyuff); anything else is read as CSV text. "Column" means a CSV column, a MAT/HDF5
    variable (a vector, 1×N or N×1), or a UFF58 time record, found by its ``id1`` text or,
    failing that, by a key ``"node:dir"`` such as ``"2:+Z"`` (response node and direction;
    directions X, Y, Z, RX, RY, RZ with an optional sign, or the numeric UFF code). See
    :mod:`bayesnsi.io.measurements` for each format's rules.

    Processing order on load (:func:`bayesnsi.io.load_signals`): each window (the estimation
    window, each validation segment) is cut from the file first - so no sample outside it
    influences it - then integrated (``integrate``), then decimated (``decimate``), then, when
    integrated without whole periods, its edges dropped (``integrate.trim_edges``), then the
    means are removed (``remove_mean``). Sample indices (``estimation``, validation ``start``/
    ``stop``) always count samples *of the file*; a decimated window ``[start, stop)`` holds
    the file samples ``start, start + q, ...`` below ``stop`` (with trimmed edges, from the
    ``edge``-th of them to the ``edge``-th before the last).

    Accelerations only: give ``accelerations`` and ``integrate`` and leave out ``outputs`` and
    ``velocities``; displacements and velocities are then derived on load, named ``x<dof>``
    (``outputs`` holds that map, so the rest of the package sees displacement channels).
    Velocity sensors only (a laser vibrometer, geophones): give ``velocities`` and ``integrate``
    and leave out ``outputs``; the displacements are their integral, the velocities are kept
    (band-filtered alike), and errors are reported in velocity.

    Parameters
    ----------
    file : Path
        Measurement file, absolute (resolved relative to the config file's folder).
    fs : float or None
        Sampling frequency of the file [Hz]; None means: take it from the file (time column or
        variable, ``fs`` variable of a MAT/HDF5 file, ``abscissa_inc`` of UFF records). When
        both are present they must agree (see :mod:`bayesnsi.io.measurements`).
    inputs : dict of str to int
        Force column -> DOF (1-based), in the order written in the config.
    outputs : dict of str to int
        Displacement column -> DOF, in the order written in the config (with ``integrate``: the
        derived channels ``x<dof>`` in the order of ``accelerations``).
    velocities : dict of str to int or None
        Measured velocity column -> DOF; the same DOFs as ``outputs`` (with ``integrate`` and no
        ``accelerations``: the velocity sensors the displacements are derived from).
    accelerations : dict of str to int
        Acceleration column -> DOF; recorded only, unless ``integrate`` is given.
    estimation : (int, int) or None
        Half-open sample window ``[start, stop)`` used for estimation; None: the whole record.
    remove_mean : bool
        Subtract each channel's mean over the estimation window (also from validation data).
    time_column : str
        Name of the time column [s], read when ``fs`` is None (and checked when present).
    integrate : IntegrationSpec or None
        Derive displacements and velocities from ``accelerations``, or displacements from
        ``velocities`` when no accelerations are given (``[data] integrate``).
    period : int or None
        Samples per period of a periodic test, counted at the file's rate (``[data] period``; a
        multiple of ``decimate``); the signals then carry ``period / decimate``. Give the
        estimation and validation windows in whole periods; leave a leading transient period out
        of them (start at ``period``). With ``integrate``, accelerations are then integrated line
        by line on the lines inside ``integrate.band_hz`` (exact for a steady state; the other
        lines are zeroed, the forces are not filtered; :func:`bayesnsi.nsi.periodic_integration`).
    realisations : int
        Realisations of the periodic test in the estimation window (``[data] realisations``, default
        1): the window holds that many consecutive realisations of equal length (new multisine
        phases, whole periods each). Each is processed on its own (integrated, its transient
        periods dropped, its periods checked) and the frequency route stacks their lines into one
        estimate (``Signals.realisations``). Needs ``period``.
    transient_periods : int
        Leading periods of each realisation of the estimation window left out as transient
        (``[data] transient_periods``, default 0); at least two periods must remain in each.
    decimate : int
        Anti-aliased down-sampling factor q >= 1 (:func:`bayesnsi.preprocess.decimate`, zero-phase
        FIR): the signals have ``fs / q``. Keep the modes below ~0.75 of the new Nyquist frequency.
    scale : dict of str to float
        Gain per column (``[data] scale = { column = factor }``), applied on load before anything
        else, e.g. force = drive gain × current; columns not named keep their values.
    units : dict of str to str
        Unit per column (``[data] units = { V1 = "V" }``) for the labels of figures and tables;
        overrides the file's units row (:func:`bayesnsi.io.units.data_units`). Never converts.
    files : dict of str to Path
        Column -> the file that holds it alone (``[data] files = { u = "u.csv", y = "y.csv" }``,
        instead of ``file``), for data shipped one channel per file (benchmark data: a headerless
        column of numbers each; :mod:`bayesnsi.io._split`). Every mapped column has a file, ``fs`` is
        required, and ``file`` is then the first of them (for messages). Empty: every column is
        read from ``file``.
    """

    file: Path
    fs: float | None
    inputs: dict[str, int]
    outputs: dict[str, int]
    velocities: dict[str, int] | None = None
    accelerations: dict[str, int] = field(default_factory=dict)
    estimation: tuple[int, int] | None = None
    remove_mean: bool = False
    time_column: str = "t"
    integrate: IntegrationSpec | None = None
    decimate: int = 1
    period: int | None = None
    realisations: int = 1
    transient_periods: int = 0
    scale: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)

    @property
    def integrated(self) -> str | None:
        """What ``integrate`` integrates: "acceleration", "velocity", or None (displacements measured)."""
        if self.integrate is None:
            return None
        return "acceleration" if self.accelerations else "velocity"

    @property
    def sensor_columns(self) -> dict[str, int]:
        """The columns ``integrate`` integrates (column -> DOF); empty without ``integrate``."""
        if self.integrate is None:
            return {}
        return dict(self.accelerations) if self.accelerations else dict(self.velocities or {})

    @property
    def signal_fs(self) -> float | None:
        """Sampling frequency of the loaded signals [Hz]: ``fs / decimate`` (None if fs is)."""
        return None if self.fs is None else self.fs / self.decimate

    @property
    def dofs(self) -> tuple[int, ...]:
        """Sorted DOFs that are forced or measured."""
        return tuple(sorted(set(self.inputs.values()) | set(self.outputs.values())))


@dataclass(frozen=True)
class ValidationSegment:
    """A stretch of data kept for validation only (``[[validation]]``).

    Parameters
    ----------
    name : str
        Label used in results.json.
    start, stop : int or None
        Half-open sample window ``[start, stop)``; None for the start or end of the record.
        Always given for segments of the estimation file.
    file : Path or None
        Another CSV with the same columns; None: the estimation file.
    files : dict of str to Path
        Another record given one channel per file, as ``[data] files`` (the same columns); empty:
        ``file``, or the estimation record.
    realisations, transient_periods : int
        As in ``[data]``: the segment holds that many equal realisations of whole periods, each
        without its transient periods, validated each from its own steady state (default 1, 0).
    integrate : IntegrationSpec or None
        How this record's sensors are integrated when not as ``[data] integrate`` (e.g. over the fitted
        band only, so that the errors compare what the model predicts, while the estimation record
        keeps the harmonics above it); None: as ``[data]``.
    period : int or None
        Samples per period of this record when it differs from ``[data] period`` (a random-odd
        multisine of another length), 0 for a record that is not periodic (a sine sweep: the
        model is simulated on the whole record); None (default): ``[data] period``, unless the
        segment's force does not repeat with it, when it is validated as not periodic (with a
        warning).
    """

    name: str
    start: int | None
    stop: int | None
    file: Path | None = None
    files: dict[str, Path] = field(default_factory=dict)
    realisations: int = 1
    transient_periods: int = 0
    period: int | None = None
    integrate: IntegrationSpec | None = None


@dataclass(frozen=True)
class ExperimentConfig:
    """A validated experiment configuration.

    Parameters
    ----------
    path : Path
        The config file, absolute.
    data : DataSpec
    nsi : NSIOptions
        ``[nsi]``.
    candidates : tuple of CandidateModel
    validation : tuple of ValidationSegment
    evidence : EvidenceOptions
        ``[evidence]``; its ``seed`` is the config's ``seed``.
    loop : LoopOptions
        ``[diagnose]``: the guards and search of the loop.
    seed : int
        Seed of every random generator of the run.
    raw : dict
        The parsed TOML, to record the settings with the results.
    meta : dict
        The free-form ``[meta]`` table (empty if absent).
    """

    path: Path
    data: DataSpec
    nsi: NSIOptions
    candidates: tuple[CandidateModel, ...]
    validation: tuple[ValidationSegment, ...]
    evidence: EvidenceOptions
    loop: LoopOptions
    seed: int
    raw: dict[str, Any]
    meta: dict[str, Any] = field(default_factory=dict)
