"""Calibration of the loop's final coefficients and modes on undeclared-effect cases.

For each case (``coulomb-dof2``: declared 20 v1|v1|, missing sign(v2) = 1 N; ``cubic-pair``:
declared linear, missing (x1-x2)³ = 2e5) and seed, it simulates the case (30 s, 2 % noise),
runs :func:`bayesnsi.loop.close_the_loop` from the declared model with default
``LoopOptions`` and the case's NSI settings, and gives the final model the intervals of
``bayesnsi select`` (:func:`bayesnsi.loop.final_intervals`, default ``interval = "auto"``:
16 noisy copies of the record, or for a final model with Coulomb friction (a sign() of a velocity)
16 records of the identified model driven by phase-randomised forces; errors-in-variables bias removed from the
centre, Student-t quantiles). It prints, as ``calibration_intervals.py`` does, per coefficient of
the final model (truth 0 for a term the truth does not hold) and per modal parameter: bias,
seed-to-seed sd, coverage of the 50 % / 95 % intervals and of the posterior-only 95 % interval,
and the mean 95 % width over 2 x 1.96 x sd; seeds whose loop did not end on the true model are
counted and left out of the coefficient rows. Then the coverage of the 95 % intervals as
``bayesnsi diagnose`` reports them: widened by the final model's residual over the noise it passes
on where that exceeds ``max_noise_ratio`` (:func:`bayesnsi.uncertainty.widening.widen_final`).

``--bit-generator`` simulates each seed's case with numpy's PCG64 (the default: ``seed`` as given
to :func:`bayesnsi.simulate.undeclared_case`), Philox or MT19937 seeded with the seed; the force
and then the noise are drawn from that one generator either way (docs/measurements.md, "The loop's Coulomb case" (vi): α's
coverage is 86-89 % under all three).

Run::

    .venv/bin/python benchmarks/calibration_loop.py --seeds 6        # a handful of seeds, 2 workers
    nice .venv/bin/python benchmarks/calibration_loop.py --seeds 100 # the full study
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import functools  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from calibration_intervals import print_case, run_seeds  # noqa: E402

CASE_NAMES = ("coulomb-dof2", "cubic-pair")


BIT_GENERATORS = ("pcg64", "philox", "mt19937")


def _case_seed(seed: int, bit_generator: str):
    """The ``seed`` argument of the case: the integer (PCG64), or a Generator on another bit generator."""
    if bit_generator == "pcg64":
        return seed
    make = {"philox": np.random.Philox, "mt19937": np.random.MT19937}[bit_generator]
    return np.random.Generator(make(seed))


def one_seed(case_name: str, seed: int, opts, bit_generator: str = "pcg64") -> dict:
    """Simulate one seed, close the loop, and compute the final model's intervals."""
    from bayesnsi.exceptions import BayesNSIError
    from bayesnsi.loop import close_the_loop, final_intervals
    from bayesnsi.options import LoopOptions
    from bayesnsi.simulate.undeclared import undeclared_case
    from bayesnsi.uncertainty.widening import widen_final

    t0 = time.perf_counter()
    case = undeclared_case(case_name, seed=_case_seed(seed, bit_generator))
    truth = dict(zip(case.reference.true_terms, case.reference.true_coefficients))
    out: dict = {"case": case_name, "seed": seed, "bit_generator": bit_generator}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            loop = close_the_loop(case.signals, case.declared, LoopOptions(), nsi=case.nsi, evidence=opts)
            primary, iv = final_intervals(loop, case.signals, opts, np.random.SeedSequence([seed, 15]))
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            out["error"] = f"{type(err).__name__}: {err}"
            return out
    terms = tuple(loop.final.terms)
    out["true_model"] = set(terms) == set(truth)
    out["final"] = [t.name for t in terms]
    # what `bayesnsi diagnose` reports: widened by the residual over the noise the model passes on when above
    # max_noise_ratio (bayesnsi/run/final_adequacy.py)
    shown, check = widen_final(loop.final, iv, case.signals)
    params = []
    for k, (term, p, q) in enumerate(zip(terms, iv.coefficients, shown.coefficients)):
        params.append({**p.to_dict(), "truth": float(truth.get(term, 0.0)),
                       "posterior_ci95": [float(v) for v in primary.ci95[k]], "diagnose_ci95": list(q.ci95)})
    exact_f, exact_z = case.reference.exact_frequencies_hz, case.reference.exact_damping_ratios
    for kind, items, widened, exact in (("f", iv.frequencies, shown.frequencies, exact_f),
                                        ("zeta", iv.damping_ratios, shown.damping_ratios, exact_z)):
        for k, (p, q) in enumerate(zip(items, widened)):
            nearest = int(np.argmin(np.abs(exact_f - loop.final.modes[k].frequency_hz)))
            params.append({**p.to_dict(), "name": f"{kind}{nearest + 1}", "truth": float(exact[nearest]),
                           "posterior_ci95": None, "diagnose_ci95": list(q.ci95)})
    out.update(method=iv.method, n_segments=iv.n_segments, params=params, seconds=time.perf_counter() - t0,
               noise_ratio=None if check is None else check.noise_ratio, widening=shown.widening)
    return out


def main(argv=None) -> int:
    from bayesnsi import EvidenceOptions

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--cases", nargs="+", default=list(CASE_NAMES), choices=CASE_NAMES)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--bit-generator", default="pcg64", choices=BIT_GENERATORS,
                    help="numpy bit generator of the simulated cases (force, then noise)")
    ap.add_argument("--json", default=None, help="write the per-seed records here")
    ap.add_argument("--tables", default=None, help="print the tables of records written by --json, and stop")
    args = ap.parse_args(argv)
    if args.tables:
        import json

        with open(args.tables) as fh:
            _print_tables(json.load(fh), args.cases)
        return 0
    task = functools.partial(one_seed, bit_generator=args.bit_generator)
    title = f"bayesnsi loop interval calibration, {args.bit_generator} cases"
    records = run_seeds(title, task, args.cases, args.seeds, args.seed0, EvidenceOptions(), args.workers,
                        json_path=args.json)
    _print_tables(records, args.cases)
    return 0


def _print_tables(records: list[dict], cases) -> None:
    for name in cases:
        mine = sorted((r for r in records if r["case"] == name), key=lambda r: r["seed"])
        wrong = [r for r in mine if "params" in r and not r["true_model"]]
        for r in wrong:
            print(f"    {name} seed {r['seed']}: loop ended on {r['final']} (not the truth), left out")
        print_case(name, [r for r in mine if r not in wrong])
        _print_diagnose_coverage([r for r in mine if r not in wrong and "params" in r])
        times = [r["seconds"] for r in mine if "seconds" in r]
        if times:
            print(f"  loop + final intervals: median {np.median(times):.1f} s per seed")


def _print_diagnose_coverage(records: list[dict]) -> None:
    """Coverage of the 95 % intervals `bayesnsi diagnose` reports (widened where the final model is inadequate)."""
    if not records or "diagnose_ci95" not in records[0]["params"][0]:
        return
    widened = [r for r in records if r.get("widening", 1.0) > 1.0]
    ratios = [r["noise_ratio"] for r in records if r.get("noise_ratio") is not None]
    print(f"  as diagnose reports them: widened on {len(widened)} of {len(records)} seeds (final model's residual "
          f"over the noise it passes on: median {np.median(ratios):.2f}, max {np.max(ratios):.2f})")
    names = [p["name"] for p in records[0]["params"]]
    for k, name in enumerate(names):
        rows = [r["params"][k] for r in records if len(r["params"]) > k and r["params"][k]["name"] == name]
        hits = [low <= row["truth"] <= high for row in rows for low, high in [row["diagnose_ci95"]]]
        print(f"  {name[:16]:<16} cov95 (diagnose) {100 * np.mean(hits):4.0f} % of {len(rows)}")


if __name__ == "__main__":
    sys.exit(main())
