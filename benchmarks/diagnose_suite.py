"""Closing the loop (SPEC 7) on undeclared-effect cases and negative controls, over seeds.

For every case of :data:`bayesnsi.simulate.undeclared.UNDECLARED_CASES`, every seed and noise
level, :func:`bayesnsi.loop.close_the_loop` starts from the declared candidate with its
default dictionary (all effect types at every measured DOF and neighbouring pair, clearances on
a gap grid) and default guards. Per case the table gives

* ``first``: runs whose first added effect has the type and location of a missing one;
* ``all``: runs that added exactly the missing effects (nothing more, nothing less);
* ``coef err``: median and worst |λ̂/λ - 1| of the found missing effects in the final model;
* ``within 10 %``: found missing effects with |λ̂/λ - 1| ≤ 0.1;
* ``after/before``: median open-loop NRMSE of the final over the declared model;
* ``nrmse ok``: runs with NRMSE after ≤ NRMSE before / 3, or at the noise floor, i.e. at most
  1.1 × the NRMSE of the true model identified by NSI on the same data (column ``truth``);
* ``floor``, ``ok/floor``: the NRMSE of the measurement noise itself (noisy against noise-free
  displacements, median) and the runs with NRMSE after ≤ before / 3 or ≤ 1.1 × that: the
  stricter reading of "at the noise floor", which the true model itself misses where the
  model has discretisation error (sign terms at 100 Hz, even upsampled twice);
* ``val a/b``, ``val ≤ ½``: closed-loop simulation NRMSE on another realisation of the case (seed +
  1000, same noise) of the final model over the declared one (median), and the runs where it is at
  most half (a model that diverges there counts as not);
* ``false add``: negative controls (and, for the others, additions that are not missing effects);
* ``s``: mean wall time of one loop.

NSI settings: the case's recommended ones (:attr:`UndeclaredCase.nsi`), overridden by
``--bd-method`` and ``--upsample R`` (block rows are then multiplied by R: they count fine-grid
samples); the true model of column ``truth`` is identified with the same settings.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose_suite.py [--seeds 5] [--noise 1 5]
[--cases NAME ...] [--bd-method METHOD] [--upsample R] [--duration S] [--no-screen | --screen N] [--verbose]``
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one BLAS thread: faster on a shared 2-core machine (SPEC 10)

import numpy as np

from bayesnsi.exceptions import BayesNSIError
from bayesnsi.loop import close_the_loop
from bayesnsi.nsi import identify
from bayesnsi.nsi.reconstruct import nrmse as _nrmse
from bayesnsi.options import EvidenceOptions, LoopOptions, NSIOptions
from bayesnsi.simulate.undeclared import UNDECLARED_CASES, undeclared_cases

FLOOR_FACTOR = 1.1  # "at the noise floor": NRMSE after ≤ 1.1 × NRMSE of the true model


def nsi_settings(case, bd_method=None, upsample=None) -> NSIOptions:
    """The case's NSI settings with the overrides of the command line."""
    nsi = case.nsi
    if bd_method is not None:
        nsi = nsi.replace(bd_method=bd_method)
    if upsample is not None:
        nsi = nsi.replace(block_rows=nsi.block_rows // nsi.upsample * upsample, upsample=upsample)
    return nsi


def closed_loop_nrmse(result, signals) -> float:
    """Closed-loop simulation NRMSE of ``result`` on ``signals`` (inf when the simulation diverges)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return float(result.reconstruct(signals, closed_loop=True).nrmse)
    except (BayesNSIError, np.linalg.LinAlgError):
        return float("inf")


def evaluate(case, loop, nsi=None, validation=None) -> dict:
    """Score one loop run against the truth of its case (and, closed loop, on another realisation)."""
    added = loop.added
    first = bool(added) and any(e.matches(added[0].effect.base, added[0].term) for e in case.missing)
    matched = [next((s for s in added if e.matches(s.effect.base, s.term)), None) for e in case.missing]
    spurious = [s for s in added if not any(s is m for m in matched)]  # wrong effects and duplicates
    final = {t: c.value for t, c in zip(loop.final.terms, loop.final.coefficients)}
    errors = [abs(final[s.term] / e.coefficient - 1.0) for e, s in zip(case.missing, matched) if s is not None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        truth = identify(case.signals, case.truth, case.nsi if nsi is None else nsi).reconstruct(case.signals).nrmse
    noise = _nrmse(case.signals.displacement, case.clean.displacement)[1]
    before = loop.start.reconstruct(case.signals).nrmse
    after = loop.final.reconstruct(case.signals).nrmse
    val = (np.nan, np.nan) if validation is None else tuple(
        closed_loop_nrmse(r, validation.signals) for r in (loop.start, loop.final))
    return dict(
        val_before=val[0],
        val_after=val[1],
        first=first,
        all=all(s is not None for s in matched) and not spurious,
        spurious=len(spurious),
        errors=errors,
        before=before,
        after=after,
        truth=truth,
        noise=noise,
        nrmse_ok=after <= before / 3 or after <= FLOOR_FACTOR * truth,
        noise_ok=after <= before / 3 or after <= FLOOR_FACTOR * noise,
        added=[s.term.name for s in added],
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="seeds per case and noise level (default 5)")
    parser.add_argument("--noise", type=float, nargs="+", default=[1.0, 5.0], help="noise levels [%%] (default 1 5)")
    parser.add_argument("--cases", nargs="+", default=list(UNDECLARED_CASES), choices=list(UNDECLARED_CASES))
    parser.add_argument("--bd-method", choices=["robust", "output-error", "prediction-error"], help="override B, D method")
    parser.add_argument("--upsample", type=int, help="override the NSI upsampling factor (block rows scaled with it)")
    parser.add_argument("--residual", choices=["innovations", "reconstruction"],
                        help="override the residual the loop scores (default: LoopOptions().residual)")
    parser.add_argument("--verbose", action="store_true", help="print every run")
    parser.add_argument("--duration", type=float, default=30.0, help="record length [s] (default 30)")
    parser.add_argument("--no-screen", action="store_true", help="re-identify every effect (close_the_loop screen=None)")
    parser.add_argument("--screen", type=int, default=None, help="effects the screen keeps (default LoopOptions().screen)")
    args = parser.parse_args()
    options = LoopOptions(
        **({"residual": args.residual} if args.residual else {}), **({"screen": None} if args.no_screen else {}),
        **({"screen": args.screen} if args.screen is not None and not args.no_screen else {})
    )
    print(f"NSI overrides: bd_method={args.bd_method}, upsample={args.upsample}; records of {args.duration:g} s; "
          f"screen {'off' if args.no_screen else options.screen}")
    header = (
        f"{'case':18} {'noise':>5} {'first':>6} {'all':>6} {'coef err med/max':>17} {'within 10%':>10} "
        f"{'after/before':>12} {'truth':>6} {'nrmse ok':>8} {'floor':>6} {'ok/floor':>8} {'val a/b':>7} "
        f"{'val ≤ ½':>7} {'false add':>9} {'s':>5}"
    )
    print(header)
    print("-" * len(header))
    for name in args.cases:
        for noise in args.noise:
            cases = undeclared_cases(name, range(args.seeds), noise, duration=args.duration)
            others = undeclared_cases(name, range(1000, 1000 + args.seeds), noise, duration=args.duration)
            rows, times = [], []
            for case, other in zip(cases, others):
                nsi = nsi_settings(case, args.bd_method, args.upsample)
                start = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    evidence = EvidenceOptions(seed=case.seed)
                    loop = close_the_loop(case.signals, case.declared, options, nsi=nsi, evidence=evidence)
                times.append(time.perf_counter() - start)
                row = evaluate(case, loop, nsi, other)
                rows.append(row)
                if args.verbose:
                    errs = ", ".join(f"{e:.3f}" for e in row["errors"])
                    print(
                        f"  seed {case.seed}: added {row['added'] or 'nothing'}; coef err [{errs}]; "
                        f"nrmse {row['before']:.4f} -> {row['after']:.4f} (truth {row['truth']:.4f}); validation "
                        f"{row['val_before']:.4f} -> {row['val_after']:.4f}; {times[-1]:.1f} s"
                    )
                    for step in loop.steps:
                        true = any(e.matches(step.effect.base, step.term) for e in case.missing)
                        h = np.abs(step.half_coefficients)
                        print(
                            f"    {'+' if step.accepted else '-'} {'TRUE' if true else 'false'} {step.term.name[:48]:48} "
                            f"logBF {step.log_bayes_factor:8.1f} imag {step.imag_ratio:5.2f} halves x{max(h) / min(h):5.2f} "
                            f"nrmse {step.nrmse_before:.4f}->{step.nrmse_after:.4f}"
                        )
            n = len(rows)
            control = cases[0].is_negative_control
            errors = [e for r in rows for e in r["errors"]]
            n_missing = n * len(cases[0].missing)
            ratio = np.median([r["after"] / r["before"] for r in rows])
            truth = np.median([r["truth"] for r in rows])
            false_add = sum(bool(r["added"]) for r in rows) if control else sum(r["spurious"] > 0 for r in rows)
            first = "-" if control else f"{sum(r['first'] for r in rows)}/{n}"
            allf = f"{sum(r['all'] for r in rows)}/{n}"
            err = f"{np.median(errors):.3f}/{np.max(errors):.3f}" if errors else "-"
            within = f"{sum(e <= 0.1 for e in errors)}/{n_missing}" if not control else "-"
            ok = "-" if control else f"{sum(r['nrmse_ok'] for r in rows)}/{n}"
            ok_noise = "-" if control else f"{sum(r['noise_ok'] for r in rows)}/{n}"
            noise_nrmse = np.median([r["noise"] for r in rows])
            val_ratio = np.median([r["val_after"] / r["val_before"] for r in rows])
            val_ok = "-" if control else f"{sum(r['val_after'] <= r['val_before'] / 2 for r in rows)}/{n}"
            print(
                f"{name:18} {noise:5.1f} {first:>6} {allf:>6} {err:>17} {within:>10} {ratio:12.3f} {truth:6.4f} "
                f"{ok:>8} {noise_nrmse:6.4f} {ok_noise:>8} {val_ratio:7.3f} {val_ok:>7} {f'{false_add}/{n}':>9} "
                f"{np.mean(times):5.1f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
