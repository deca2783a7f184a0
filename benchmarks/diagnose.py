"""Cost of closing the loop (SPEC 7) against one `select` of a single candidate.

For the two-DOF case (declared model 1 {v1|v1|}) and the beam case (declared {x13², x13³}),
both with nothing missing (the identified models without one of the beam's two terms are
unstable, so the loop cannot start from them): wall time of a full loop
(:func:`bayesnsi.loop.close_the_loop`, default dictionary and guards), the number of loop
steps and of effects scored, and the time of one select of a single candidate: the numerical
part (NSI + reconstruction + AR(1) evidence) and the whole ``bayesnsi select`` command on a
config holding only that candidate (adds the white-noise evidence, closed-loop checks and the
report with its figures). Target: a loop step costs no more than one select.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/diagnose.py [--quick] [--jobs N] [--no-screen]``
(``--quick``: two-DOF only; ``--jobs N``: the loop scores each step's effects in N worker processes;
``--no-screen``: every effect re-identified, as before the frequency-domain screen)
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one BLAS thread: faster on a shared 2-core machine (SPEC 10)

import numpy as np  # noqa: E402

from bayesnsi.evidence import candidate_evidence  # noqa: E402
from bayesnsi.loop import close_the_loop  # noqa: E402
from bayesnsi.models import CandidateModel  # noqa: E402
from bayesnsi.nsi import identify  # noqa: E402
from bayesnsi.options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions  # noqa: E402
from bayesnsi.simulate import simulate_case  # noqa: E402

CASES = {
    "two-dof": (CandidateModel.from_terms("declared", [("v1*abs(v1)", 1)]), NSIOptions(block_rows=60, order=4)),
    "beam": (
        CandidateModel.from_terms("declared", [("x13**2", 13), ("x13**3", 13)]),
        NSIOptions(block_rows=40, order=32, band_hz=(1.0, 30.0)),
    ),
}


def cli_select_seconds(case, candidate, nsi) -> float:
    """Wall time of ``bayesnsi select`` on a one-candidate config of ``case`` (report included)."""
    import tempfile
    from pathlib import Path

    from bayesnsi.cli import main as cli_main
    from bayesnsi.cli.simulate import case_config
    from bayesnsi.io import dump_config, write_signals_csv
    from bayesnsi.io.schema import term_record

    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "data.csv"
        config = case_config(case, write_signals_csv(csv, case.signals))
        config["candidates"] = [{"name": candidate.name, "terms": [term_record(t) for t in candidate.terms]}]
        config["nsi"] = {k: v for k, v in nsi.to_dict().items() if v is not None}
        (Path(tmp) / "one.toml").write_text(dump_config(config))
        start = time.perf_counter()
        code = cli_main(["select", str(Path(tmp) / "one.toml"), "--out", str(Path(tmp) / "out"), "--quiet"])
        elapsed = time.perf_counter() - start
    if code:
        raise RuntimeError(f"bayesnsi select failed with exit code {code}")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--jobs", type=int, default=1, help="score each step's effects in N worker processes")
    parser.add_argument("--no-screen", action="store_true", help="re-identify every effect (close_the_loop screen=None)")
    args = parser.parse_args()
    names = ["two-dof"] if args.quick else list(CASES)
    screen = {"screen": None} if args.no_screen else {}  # {}: the default screen of LoopOptions
    options = LoopOptions(max_steps=2, **screen)
    print(f"loop effects scored in {args.jobs} worker process(es); screen {'off (every effect re-identified)' if screen else 'on'}")
    print(f"{'case':8} {'select 1 cand [s]':>18} {'CLI select [s]':>15} {'loop [s]':>9} {'steps':>6} {'effects':>8} "
          f"{'s / step':>9}  added")
    for name in names:
        case = simulate_case(name, seed=0)
        candidate, nsi = CASES[name]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            start = time.perf_counter()
            result = identify(case.signals, candidate, nsi)
            result.reconstruct(case.signals)
            candidate_evidence(result, case.signals, EvidenceOptions(compare=()), np.random.SeedSequence(0))
            select_time = time.perf_counter() - start
            cli_time = cli_select_seconds(case, candidate, nsi)
            start = time.perf_counter()
            loop = close_the_loop(case.signals, candidate, options, nsi=nsi, execution=ExecutionOptions(jobs=args.jobs))
            loop_time = time.perf_counter() - start
        steps = max(len(loop.scores), 1)
        added = ", ".join(s.term.name for s in loop.added) or "nothing"
        n_effects = loop.settings["n_effects"]
        print(f"{name:8} {select_time:18.2f} {cli_time:15.2f} {loop_time:9.1f} {steps:6d} {n_effects:8d} "
              f"{loop_time / steps:9.1f}  {added}")


if __name__ == "__main__":
    main()
