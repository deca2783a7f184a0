"""Selection on the simulated ground vibration test: is the selected model the one that validates?

Per level of :func:`bayesnsi.simulate.gvt_records` (0.1, 1 and 8 N rms; realisation 0 estimates,
realisation 1 validates; accelerations integrated period by period in 1-20 Hz), ``select`` runs on a
candidate set that holds

- ``joint 7-8`` - the right joint: ``tanh((v7-v8)/ε)`` and ``(x7-x8)**3`` between DOFs 7 and 8;
- ``joint 2-7`` - the same element at the wrong location (between sensors 2 and 7);
- ``damping 7-8`` - an element of the wrong type at the right place: ``(v7-v8)|v7-v8|`` and
  ``(x7-x8)**2``;
- ``linear`` - no joint,

with the settings of ``workflows/gvt.py`` (frequency route, band 1.5-15 Hz, order 20, 20 block rows,
D free) and default evidence settings (AR(1) primary). Printed per level and candidate: log Z, posterior
probability, validation NRMSE (closed loop on realisation 1) and the residual-to-noise ratio; then
the selected model's validation NRMSE over the best candidate's (target: at most 1.10) and the
adequacy warnings select gave.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/gvt_selection.py
    ... benchmarks/gvt_selection.py --levels 8 --seed 1 --time-domain
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

from bayesnsi import NSIOptions, Signals  # noqa: E402
from bayesnsi.models import CandidateModel  # noqa: E402
from bayesnsi.nsi import periodic_integration  # noqa: E402
from bayesnsi.options import EvidenceOptions  # noqa: E402
from bayesnsi.selection import select  # noqa: E402
from bayesnsi.simulate import GVT_BAND_HZ, GVT_SENSORS, GVT_SHAKER, gvt_records  # noqa: E402

LEVELS = (0.1, 1.0, 8.0)
EPS = "0.002"  # the joint's friction smoothing velocity [m/s] (bayesnsi/simulate/gvt.py)


def candidates() -> list:
    """Right joint, wrong location, wrong type, linear."""
    return [
        CandidateModel.from_terms("joint 7-8", [(f"tanh((v7-v8)/{EPS})", (7, 8)), ("(x7-x8)**3", (7, 8))]),
        CandidateModel.from_terms("joint 2-7", [(f"tanh((v2-v7)/{EPS})", (2, 7)), ("(x2-x7)**3", (2, 7))]),
        CandidateModel.from_terms("damping 7-8", [("(v7-v8)*abs(v7-v8)", (7, 8)), ("(x7-x8)**2", (7, 8))]),
        CandidateModel.from_terms("linear", []),
    ]


def signals(record) -> Signals:
    """Force and the integrated accelerations of one record."""
    velocity, displacement = periodic_integration(record.acceleration, record.fs, record.period, (1.0, 20.0))
    return Signals(force=record.force, displacement=displacement, velocity=velocity, fs=record.fs,
                   input_dofs=(GVT_SHAKER,), output_dofs=GVT_SENSORS, period=record.period)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", type=float, nargs="+", default=list(LEVELS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--order", type=int, default=20)
    parser.add_argument("--time-domain", action="store_true", help="the time route instead of the frequency route")
    parser.add_argument("--likelihood", default="ar1")
    args = parser.parse_args()
    records = gvt_records(levels=tuple(args.levels), n_realisations=2, seed=args.seed)
    nsi = NSIOptions(order=args.order, block_rows=20, zero_feedthrough=False,
                     **({} if args.time_domain else {"domain": "frequency", "band_hz": GVT_BAND_HZ}))
    evidence = EvidenceOptions(likelihood=args.likelihood)
    print(f"seed {args.seed}, order {args.order}, {'time' if args.time_domain else 'frequency'} route, "
          f"{args.likelihood} likelihood")
    ratios = []
    for level in args.levels:
        est, val = (signals(r) for r in records if r.level == level)
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            sel = select(est, candidates(), nsi, evidence, validation=[("realisation 1", val)])
        seconds = time.perf_counter() - t0
        print(f"\nlevel {level:g} N ({seconds:.0f} s)")
        print(f"{'candidate':>12} | {'log Z':>12} {'P':>6} | {'val NRMSE':>9} {'resid/noise':>11} {'quality':>7}")
        table = sel.table
        for name, check in sel.checks.items():
            log_z = table.loc[name, f"log_evidence_{sel.likelihood}"] if table is not None else float("nan")
            prob = table.loc[name, f"p_{sel.likelihood}"] if table is not None else float("nan")
            quality = "-" if check.quality_index is None else f"{check.quality_index:.3f}"
            nrmse = float("nan") if check.validation_nrmse is None else check.validation_nrmse
            print(f"{name:>12} | {log_z:12.2f} {prob:6.3f} | {nrmse:9.4f} {check.noise_ratio:11.2f} {quality:>7}")
        for outcome in sel.outcomes:
            if outcome.status != "ok":
                print(f"{outcome.name:>12} | failed: {outcome.error}")
        nrmses = {n: c.validation_nrmse for n, c in sel.checks.items() if c.validation_nrmse is not None}
        if sel.selected in nrmses and nrmses:
            best = min(nrmses, key=nrmses.get)
            ratio = nrmses[sel.selected] / nrmses[best]
            ratios.append(ratio)
            verdict = "met" if ratio <= 1.10 else "NOT met"
            print(f"selected {sel.selected!r}; best validating {best!r}; ratio {ratio:.3f} ({verdict}, target <= 1.10)")
        else:
            print(f"selected {sel.selected!r}: no validation error to compare")
        for message in sel.warnings:
            print(f"  warning: {message}")
    if ratios:
        print(f"\nworst ratio over the levels: {max(ratios):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
