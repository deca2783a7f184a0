"""``bayesnsi simulate CASE --seed S [--noise P] --out FILE.csv``: a reference case and its config."""

from __future__ import annotations

from pathlib import Path

from ..exceptions import InputDataError
from ._common import progress

__all__ = ["add_parser", "run", "case_config"]


class _CaseNames:
    """The simulated cases, looked up only when needed (parsing ``simulate``, its help): importing
    :mod:`bayesnsi.simulate` costs scipy, which ``bayesnsi --help`` must not pay."""

    @staticmethod
    def _names() -> list[str]:
        from ..simulate import CASES, UNDECLARED_CASES

        return sorted(CASES) + sorted(UNDECLARED_CASES)

    def __contains__(self, name) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(self._names())


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "simulate",
        help="simulate a reference case of the paper or an undeclared-effect case to CSV + config",
        description="Simulate a reference case of the paper and write FILE.csv (with a units row) and, beside "
        "it, FILE.toml: an experiment config with the paper's candidate set, ready for `bayesnsi identify`/`select`. "
        "The undeclared-effect cases (coulomb-dof2, cubic-pair, ..., and the controls control-*) hold an effect "
        "that the config's one candidate does not declare (or, for the controls, nothing missing): data to try "
        "`bayesnsi diagnose` on; the config's [meta] names what is missing.",
        epilog="examples: bayesnsi simulate two-dof --seed 3 --noise 2 --out data/two_dof.csv\n"
        "          bayesnsi simulate coulomb-dof2 --seed 1 --out data/coulomb.csv && "
        "bayesnsi diagnose data/coulomb.toml --out out/loop",
    )
    p.add_argument(
        "case", choices=_CaseNames(), metavar="CASE", help="reference or undeclared-effect case: %(choices)s"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--noise", type=float, default=None, help="output noise in %% of each signal's std")
    p.add_argument("--duration", type=float, default=None, help="record length [s] (default: the paper's)")
    p.add_argument("--out", required=True, help="CSV file to write (the config gets the .toml suffix)")
    p.add_argument("--force", action="store_true", help="overwrite existing files")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(run=run)


def case_config(case, data_table: dict) -> dict:
    """Experiment config of a simulated case, as a plain dict for ``dump_config``."""
    from ..io.schema import term_record

    rec = case.recommended
    defaults = type(rec)().to_dict()
    nsi = {"block_rows": rec.block_rows, "order": rec.order}
    nsi.update({k: v for k, v in rec.to_dict().items() if v != defaults[k] and v is not None})
    return {
        "seed": int(case.seed or 0),
        "data": data_table,
        "nsi": nsi,
        "candidates": [
            {"name": c.name, "prior": float(c.prior), "terms": [term_record(t) for t in c.terms]}
            for c in case.candidates
        ],
        "meta": {
            "case": case.name,
            "true_model": case.true_model,
            "true_terms": [t.expr.text for t in case.true_terms],
            "true_coefficients": [float(c) for c in case.true_coefficients],
            "exact_frequencies_hz": [float(f) for f in case.exact_frequencies_hz],
            "exact_damping_ratios": [float(z) for z in case.exact_damping_ratios],
            "noise_percent": float(case.noise_percent),
            "M": case.M.tolist(),
            "C": case.C.tolist(),
            "K": case.K.tolist(),
        },
    }


def run(args) -> int:
    """Execute the command."""
    from ..io import atomic_write_text, dump_config, write_signals_csv
    from ..simulate import simulate_case

    csv_path = Path(args.out).expanduser().resolve()
    if csv_path.suffix.lower() != ".csv":
        raise InputDataError(f"--out must name a .csv file, got {args.out!r}")
    toml_path = csv_path.with_suffix(".toml")
    for path in (csv_path, toml_path):
        if path.exists() and not args.force:
            raise InputDataError(f"{path} exists; pass --force to overwrite it or choose another --out")
    try:
        csv_path.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError) as exc:  # a file on the way, e.g. /dev/null/x.csv
        raise InputDataError(f"cannot create the folder {csv_path.parent} of --out: {exc.strerror}") from exc
    from ..simulate import UNDECLARED_CASES, undeclared_case

    kwargs = {} if args.duration is None else {"duration": args.duration}
    progress(f"simulating {args.case} (seed {args.seed}) ...", args.quiet)
    missing = None
    if args.case in UNDECLARED_CASES:
        noise = 2.0 if args.noise is None else args.noise
        undeclared = undeclared_case(args.case, seed=args.seed, noise_percent=noise, **kwargs)
        case, missing = undeclared.reference, undeclared.missing
    else:
        case = simulate_case(args.case, seed=args.seed, noise_percent=args.noise, **kwargs)
    sig = case.signals  # the simulated structures are in SI units
    units = {name: "N" for name in sig.input_names} | {name: "m" for name in sig.output_names}
    units |= {f"v{dof}": "m/s" for dof in sig.output_dofs} | {f"{name}_velocity": "m/s" for name in sig.output_names}
    data_table = write_signals_csv(csv_path, sig, units=units)
    config = case_config(case, data_table)
    if missing is not None:
        config["meta"]["missing"] = [
            {"type": e.effect_type, "expr": e.term.expr.text, "at": list(e.term.at), "coefficient": e.coefficient}
            for e in missing
        ]
    atomic_write_text(toml_path, dump_config(config))
    progress(f"wrote {csv_path} ({case.signals.n_samples} samples) and {toml_path}", args.quiet)
    return 0
