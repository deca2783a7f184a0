"""Typed, frozen settings of each layer: identification, evidence, the loop, execution.

Every option of bayesnsi is a field of one of these dataclasses, with its default, check and help
text written once, here (``help(NSIOptions)`` lists them). The config's tables (``[nsi]``,
``[evidence]``, ``[diagnose]``), the command line, the Python API and the cache key read the same
fields; ``results.json`` records :meth:`to_dict`. An instance is validated when it is built.

Examples
--------
>>> from bayesnsi.options import NSIOptions
>>> NSIOptions(block_rows=60, order=4).block_rows
60
>>> NSIOptions.from_mapping({"block_rows": 60, "band_hz": [1.0, 10.0]}).band_hz
(1.0, 10.0)
>>> NSIOptions(block_rows=0)
Traceback (most recent call last):
...
bayesnsi.exceptions.ConfigError: [nsi] block_rows: expected an integer in [1, 100000], got 0
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

from .exceptions import ConfigError

__all__ = [
    "EvidenceOptions",
    "ExecutionOptions",
    "LoopOptions",
    "NSIOptions",
    "MAX_BLOCK_ROWS",
    "MAX_JOBS",
    "MAX_UPSAMPLE",
    "option_help",
    "parse_likelihood",
]

MAX_BLOCK_ROWS = 100_000
"""Largest number of block rows accepted (the Hankel products grow with its square)."""
MAX_UPSAMPLE = 64
"""Largest identification-grid refinement accepted (cost grows with its square)."""
MAX_WALKERS = 10_000
"""Largest emcee ensemble accepted."""
MAX_STEPS = 10_000_000
"""Largest number of emcee steps per walker accepted."""
MAX_JOBS = 256
"""Largest number of local worker processes accepted."""


def _option(default: Any, help: str, *, kind: str, choices: tuple = (), low: float | None = None,
            high: float | None = None, none: bool = False):
    """A dataclass field that carries its help text and its check (kind, choices, range)."""
    meta = {"help": help, "kind": kind, "choices": choices, "low": low, "high": high, "none": none}
    return field(default=default, metadata=meta)


class _Options:
    """Shared behaviour of the options dataclasses: build from a table, check, serialise."""

    SECTION: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for item in fields(self):  # type: ignore[arg-type]
            value = _coerce(self.SECTION, item, getattr(self, item.name))
            object.__setattr__(self, item.name, value)
        self._check()

    def _check(self) -> None:
        """Checks across fields (overridden where needed)."""

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The option names: the keys of the config table and the fields of the class."""
        return tuple(item.name for item in fields(cls))  # type: ignore[arg-type]

    @classmethod
    def from_mapping(cls, table: Mapping[str, Any] | None = None, **overrides: Any):
        """Build from a config table (unknown keys refused), with keyword overrides.

        Parameters
        ----------
        table : mapping, optional
            Option name -> value, e.g. a parsed TOML table. Lists become tuples.
        **overrides
            Values that take precedence over ``table``.

        Returns
        -------
        options of this class

        Raises
        ------
        ConfigError
            On an unknown key or an invalid value; the message names the key.
        """
        merged = {**dict(table or {}), **overrides}
        unknown = sorted(set(merged) - set(cls.names()))
        if unknown:
            raise ConfigError(
                f"[{cls.SECTION}] has unknown key(s) {unknown}; allowed: {sorted(cls.names())}"
            )
        return cls(**merged)

    def replace(self, **changes: Any):
        """A copy with some options changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready values (tuples as lists), as recorded in results.json ``settings``."""
        return {item.name: _plain(getattr(self, item.name)) for item in fields(self)}  # type: ignore[arg-type]


def option_help(options_class: type) -> dict[str, str]:
    """Help text of each option of an options class (for the CLI and the docs).

    Parameters
    ----------
    options_class : type
        One of the options dataclasses of this module (e.g. :class:`NSIOptions`).

    Returns
    -------
    dict of str to str
        Option name -> one-line help text, in field order.
    """
    return {item.name: item.metadata["help"] for item in fields(options_class)}


@dataclass(frozen=True)
class NSIOptions(_Options):
    """Settings of the subspace identification (config ``[nsi]``; docs/method.md §3-4).

    Each field's help text (:func:`option_help`) states its meaning; measurements behind the
    defaults are in ``docs/measurements.md``.
    """

    SECTION: ClassVar[str] = "nsi"

    block_rows: int = _option(40, "i, block rows of the Hankel matrices", kind="int", low=1, high=MAX_BLOCK_ROWS)
    order: int | str = _option("auto", 'model order n, or "auto" (largest gap of the singular values)', kind="order")
    max_order: int = _option(
        40, 'largest order "auto" and the stabilisation diagram consider', kind="int", low=1, high=10_000)
    band_hz: tuple[float, float] | None = _option(
        None, "band [Hz] over which λ(ω) is averaged (default: the band holding the modes)", kind="band", none=True)
    band_mean: str = _option(
        "auto", "how Re λ(ω) is averaged over the band on the time route: weighted by the power the term puts on "
        "the outputs over the sensor noise at each line (information; to first order its inverse variance), the "
        "plain mean of the paper, or auto: information for records integrated from accelerometers or velocity "
        "sensors, whose noise grows as 1/ω⁴ or 1/ω² towards the integration corner, plain otherwise",
        kind="choice", choices=("auto", "information", "plain"))
    velocity_method: str = _option(
        "fourth", "finite-difference stencil for velocities not measured", kind="choice",
        choices=("central", "fourth", "sixth"))
    route: str = _option(
        "correlation", "Hankel products from one-pass correlations, or the LQ reference", kind="choice",
        choices=("correlation", "lq"))
    bd_method: str = _option(
        "output-error", "estimator of B and D", kind="choice", choices=("robust", "output-error", "prediction-error"))
    zero_feedthrough: bool = _option(True, "impose D = 0 (displacement outputs)", kind="bool")
    input_hold: str = _option(
        "auto", "extended input over a sample interval: point value or interval mean", kind="choice",
        choices=("auto", "average", "sample"))
    upsample: int = _option(
        1, "identify on a grid this many times finer than the data (sign() terms); block_rows counts samples of "
        "that grid: scale it by the same factor (as the loop's final re-identification does)", kind="int", low=1,
        high=MAX_UPSAMPLE)
    refine_poles: tuple[float, float] | None = _option(
        None, "band [Hz] whose poles are refined by output error", kind="band", none=True)
    c_method: str = _option(
        "subspace", "C from the subspace step or re-fitted by prediction error", kind="choice",
        choices=("subspace", "prediction-error"))
    domain: str = _option(
        "time", 'identify from the time samples, or "frequency" (FNSI on the excited lines of periodic data; '
        "needs [data] period)", kind="choice", choices=("time", "frequency"))
    virtual_stiffness: float | str = _option(
        "auto", 'known spring [N/m] added at forced, measured DOFs so that free bodies identify (rigid-body '
        'pole z = 1), removed again from modes, FRF and physical parameters; "auto": only when the data '
        "hold a rigid-body pole, with k = std(force)/std(displacement); 0: never", kind="auto-number")

    def _check(self) -> None:
        if self.c_method == "prediction-error" and self.bd_method != "prediction-error":
            raise ConfigError('[nsi] c_method = "prediction-error" needs bd_method = "prediction-error"')


@dataclass(frozen=True)
class EvidenceOptions(_Options):
    """Settings of the marginal evidence (config ``[evidence]``; docs/method.md §6)."""

    SECTION: ClassVar[str] = "evidence"

    residual: str = _option(
        "innovations", "residual the evidence scores: Kalman innovations or open-loop reconstruction error "
        "(a free body, one DOF with a rigid-body pole: always the force predicted from the measured motion)",
        kind="choice", choices=("innovations", "reconstruction"))
    likelihood: str = _option("ar1", "primary likelihood: white, ar1 or arP (P an integer)", kind="likelihood")
    compare: tuple[str, ...] = _option(("white",), "likelihoods reported beside the primary one", kind="likelihoods")
    n_walkers: int = _option(32, "emcee walkers", kind="int", low=4, high=MAX_WALKERS)
    n_steps: int = _option(1500, "emcee steps per walker", kind="int", low=2, high=MAX_STEPS)
    n_burn: int = _option(300, "steps discarded as burn-in (fewer than n_steps)", kind="int", low=0, high=MAX_STEPS)
    reference_force_rms: float | None = _option(
        None, "force [N] that scales the default coefficient priors (default: rms of the measured forces)",
        kind="float", low=0.0, none=True)
    seed: int = _option(0, "root seed of every random draw (emcee walkers, Monte-Carlo errors)", kind="int",
                        low=0, high=2**63 - 1)
    interval: str = _option(
        "auto", "intervals of coefficients and modes: the posterior given the linear part, widened by the "
        "scatter of the identification over sub-records (segments), or the scatter and errors-in-variables bias "
        "over copies of the record with added sensor noise (noise) or over records of the identified model driven "
        "by phase-randomised forces (surrogate); auto: surrogate for a candidate with Coulomb friction (a sign() of "
        "velocities alone) on a single non-periodic record of a grounded structure, else noise", kind="choice",
        choices=("auto", "posterior", "segments", "noise", "surrogate"))
    n_replicates: int = _option(16, "noisy copies of the record re-identified for the noise interval", kind="int",
                                low=2, high=1000)
    n_segments: int = _option(8, "sub-records re-identified for the segments interval", kind="int", low=2, high=1000)
    segment_fraction: float = _option(
        0.7, "length of a sub-record as a fraction of the record (segments interval)", kind="float", low=0.05,
        high=0.95)
    max_noise_ratio: float = _option(
        1.3, "adequacy: largest ratio of a candidate's open-loop residual rms to that of the noise it passes on "
        "(its residual's change when fresh sensor noise is added to the data)", kind="float", low=1.0)
    max_band_ratio: float = _option(
        2.0, "adequacy: largest residual-to-passed-on-noise ratio in any frequency band before select warns; also "
        "the misfit above which a quality index is judged against the model's misfit", kind="float", low=1.0)
    max_imag_ratio: float = _option(
        0.3, "adequacy: largest quality index |Im λ|/|Re λ| of the selected model", kind="float", low=0.0)
    noise_floor: float | None = _option(
        None, "lower end of the noise prior as a multiple of std(y) (default: the smaller of 1e-4 and a tenth of "
        "the output's white-noise level, so that precise data are not refused)", kind="float", low=0.0, none=True)

    def _check(self) -> None:
        if self.n_burn >= self.n_steps:
            raise ConfigError(
                f"[evidence] n_burn ({self.n_burn}) must be smaller than n_steps ({self.n_steps}); "
                "lower n_burn or raise n_steps"
            )
        if self.reference_force_rms is not None and self.reference_force_rms <= 0:
            raise ConfigError(f"[evidence] reference_force_rms must be positive, got {self.reference_force_rms!r}")
        if self.noise_floor is not None and not 0 < self.noise_floor < 10.0:
            raise ConfigError(
                f"[evidence] noise_floor must lie in (0, 10) (a multiple of std(y)), got {self.noise_floor!r}"
            )

    @property
    def likelihoods(self) -> tuple[str, ...]:
        """The primary likelihood, then the compared ones (each once)."""
        return tuple(dict.fromkeys((self.likelihood, *self.compare)))


@dataclass(frozen=True)
class LoopOptions(_Options):
    """Settings of the loop that closes the model on its residual (config ``[diagnose]``; docs/method.md §7).

    The guards (``threshold``, ``max_imag_ratio``, ``stability_factor``), the search
    (``screen``, ``n_tries``, ``lookahead``, ``max_steps``) and the dictionary (``effects``) are
    explained in :func:`bayesnsi.loop.close_the_loop`.
    """

    SECTION: ClassVar[str] = "diagnose"

    residual: str = _option(
        "reconstruction", "residual the effects are scored on (see close_the_loop)", kind="choice",
        choices=("innovations", "reconstruction"))
    threshold: float = _option(
        float(math.log(100.0)), "smallest log Bayes factor that accepts an effect", kind="float", low=0.0)
    max_imag_ratio: float = _option(0.3, "largest quality index |Im λ|/|Re λ| accepted", kind="float", low=0.0)
    stability_factor: float = _option(
        1.4, "largest ratio of the record-half coefficient estimates", kind="float", low=1.0)
    max_shared: float = _option(
        0.5, "largest squared partial correlation of a new effect's column with an effect the loop added",
        kind="float", low=0.0, high=1.0)
    max_steps: int = _option(3, "most effects added", kind="int", low=0, high=1000)
    n_tries: int = _option(
        3, "effects checked per step, best first (one whose quality index or dissipation fails does not count)",
        kind="int", low=1, high=1000)
    lookahead: bool = _option(True, "try a pair when an effect fails only the quality index", kind="bool")
    accept_quality_only: bool = _option(
        False, "accept an effect whose only failed check is the quality index (the evidence favours it and its "
        "record halves agree)", kind="bool")
    refine_final: int | None = _option(
        4, "upsample factor of the final re-identification of friction-like models (none: off)", kind="int",
        low=2, high=MAX_UPSAMPLE, none=True)
    screen: int | None = _option(
        6, "effects re-identified per step after the frequency-domain screen (none: all)", kind="int",
        low=1, high=100_000, none=True)
    effects: tuple[str, ...] | None = _option(
        None, 'effect types tried at the measured DOFs, e.g. ["x^3", "sign(v)", "clearance"] (none: all; '
        "the names are checked against bayesnsi.models.EFFECT_TYPES when the loop builds its dictionary)",
        kind="any", none=True)

    def _check(self) -> None:
        if self.effects is None:
            return
        names = self.effects
        if not isinstance(names, (list, tuple)) or not names or not all(isinstance(n, str) for n in names):
            raise ConfigError(
                f"[diagnose] effects: expected a non-empty list of effect type names, got {_shown(self.effects)}"
            )
        object.__setattr__(self, "effects", tuple(dict.fromkeys(names)))


@dataclass(frozen=True)
class ExecutionOptions(_Options):
    """Where and how candidates and effects run (command line ``--jobs``, ``--scheduler``, cache).

    These never change a number: every task carries its own seed, and a cache entry is keyed by
    everything its result depends on.
    """

    SECTION: ClassVar[str] = "execution"

    jobs: int = _option(1, "local worker processes", kind="int", low=1, high=MAX_JOBS)
    scheduler: Any = _option(None, "Dask scheduler address (or a connected Client)", kind="any", none=True)
    cache: Any = _option(
        None, "result cache: key(signals, candidate, nsi, evidence, seed_sequence), load(key), store(key, outcome)",
        kind="any", none=True)
    progress: Any = _option(
        None, "called as progress(candidate_index, outcome) when a candidate is done "
        "(run_datasets: progress(dataset_index, candidate_index, outcome))", kind="any", none=True)


def parse_likelihood(name: str) -> tuple[int, str]:
    """AR order and canonical name of a likelihood name: ``"white"``, ``"ar1"``, ``"arP"``.

    Parameters
    ----------
    name : str

    Returns
    -------
    (int, str)
        AR order (0 for white) and the name.

    Raises
    ------
    ConfigError
        For any other name.
    """
    if name == "white":
        return 0, name
    if isinstance(name, str) and name.startswith("ar") and name[2:].isdigit() and 1 <= int(name[2:]) <= 50:
        return int(name[2:]), name
    raise ConfigError(f"likelihood {_shown(name)} unknown; use 'white', 'ar1' or 'arP' (P an integer from 1 to 50)")


def _coerce(section: str, item, value):
    """Check one option value against its field's kind, choices and range; normalise it."""
    meta = item.metadata
    where = f"[{section}] {item.name}"
    if value is None and meta["none"]:
        return None
    kind = meta["kind"]
    if kind == "any":
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, got {_shown(value)}")
        return value
    if kind == "choice":
        if value not in meta["choices"]:
            raise ConfigError(f"{where}: expected one of {list(meta['choices'])}, got {_shown(value)}")
        return value
    if kind == "likelihood":
        return parse_likelihood(value)[1]
    if kind == "likelihoods":
        values = [value] if isinstance(value, str) else value
        if not isinstance(values, (list, tuple)):
            raise ConfigError(f"{where}: expected a likelihood name or a list of them, got {_shown(value)}")
        return tuple(parse_likelihood(v)[1] for v in values)
    if kind == "auto-number":
        if value == "auto":
            return value
        return _number(where, value, integer=False, low=0.0, high=None, extra=' or "auto"')
    if kind == "order":
        if value == "auto":
            return value
        return _number(where, value, integer=True, low=1, high=10_000, extra=' or "auto"')
    if kind == "band":
        ok = isinstance(value, (list, tuple)) and len(value) == 2
        pair = tuple(_number(where, v, integer=False, low=0.0, high=None) for v in value) if ok else ()
        if not ok or not pair[0] < pair[1]:
            raise ConfigError(f"{where}: expected [low, high] in Hz with 0 <= low < high, got {_shown(value)}")
        return pair
    return _number(where, value, integer=kind == "int", low=meta["low"], high=meta["high"])


def _number(where: str, value, *, integer: bool, low, high, extra: str = ""):
    is_int = isinstance(value, int) and not isinstance(value, bool)
    is_real = is_int or (isinstance(value, float) and math.isfinite(value))
    if is_int and not integer and not abs(value) <= sys.float_info.max:
        is_real = False  # an integer beyond every float: float() would overflow
    if integer and isinstance(value, float) and value.is_integer() and math.isfinite(value):
        value, is_int = int(value), True
    if (
        (integer and not is_int)
        or not is_real
        or (low is not None and value < low)
        or (high is not None and value > high)
    ):
        span = f"[{_fmt(low)}, {_fmt(high)}]" if high is not None else f">= {_fmt(low)}"
        noun = "an integer" if integer else "a finite number"
        raise ConfigError(f"{where}: expected {noun} in {span}{extra}, got {_shown(value)}")
    return int(value) if integer else float(value)


def _shown(value) -> str:
    """``repr`` of a refused value for a one-line message: shortened, safe for any integer."""
    try:
        text = repr(value)
    except ValueError:  # an integer with more digits than Python converts to text
        return "an integer too large to print"
    return text if len(text) <= 80 else text[:77] + "..."


def _fmt(bound) -> str:
    return "-inf" if bound is None else f"{bound:g}" if isinstance(bound, float) else str(bound)


def _plain(value):
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)


_KIND_TEXT = {"bool": "true or false", "order": 'integer >= 1 or "auto"', "band": "[low, high] in Hz",
              "likelihood": '"white", "ar1" or "arP"', "likelihoods": "list of likelihood names",
              "auto-number": 'number >= 0 or "auto"', "any": "any object"}


def _range_text(meta: Mapping[str, Any]) -> str:
    """The accepted values of an option, in words."""
    kind, low, high = meta["kind"], meta["low"], meta["high"]
    noun = "integer" if kind == "int" else "number"
    text = ("one of " + ", ".join(repr(c) for c in meta["choices"]) if kind == "choice"
            else f"{noun} in [{_fmt(low)}, {_fmt(high)}]" if kind in ("int", "float") and high is not None
            else f"{noun} >= {_fmt(low)}" if kind in ("int", "float") else _KIND_TEXT.get(kind, kind))
    return text + (", or none" if meta["none"] else "")


for _cls in (NSIOptions, EvidenceOptions, LoopOptions, ExecutionOptions):  # help(): each field's meaning and range
    _cls.__doc__ = (_cls.__doc__ or "").rstrip() + "\n\n    Parameters\n    ----------\n" + "".join(
        f"    {item.name} : {_range_text(item.metadata)}; default {item.default!r}\n        {item.metadata['help']}.\n"
        for item in fields(_cls))
