"""Wall time of :func:`bayesnsi.select` at 1e5 samples with 2 and with 16 output channels, in a warm process.

16 channels: the beam of ``benchmarks/evidence_channels.py`` (all 16 DOFs measured, 100 s at 1 kHz,
1 % noise), its true candidate {x13², x13³} at i = 10, n = 32; 2 channels: the two-DOF case (1000 s at
100 Hz, 1 % noise), its three paper candidates at the paper settings. Default evidence settings
(AR(1) + white, 16 noise replicates for the intervals, the model check). A short ``select`` first
imports and warms everything; then the best of ``--repeats`` runs, each on a fresh copy of the record
(its noise levels, kept with a record once measured, are measured again). Run it against another checkout
with ``PYTHONPATH=<checkout>`` to compare two versions (interleave the runs: the host's speed drifts).

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/select_cost.py [--channels 2 16]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import bayesnsi
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.selection import select
from bayesnsi.simulate.reference import case_setup, run_setup


def case_of(n_channels: int):
    """Signals, candidates and NSI settings of the 2- or 16-channel case."""
    if n_channels == 16:
        setup = dataclasses.replace(case_setup("beam", duration=100.0), output_dofs=tuple(range(1, 17)))
        (case,) = run_setup(setup, [0], 1.0)
        return case.signals, [case.candidates[2]], NSIOptions(block_rows=10, order=32)
    setup = dataclasses.replace(case_setup("two-dof", duration=1000.0), output_dofs=(1, 2))
    (case,) = run_setup(setup, [0], 1.0)
    return case.signals, list(case.candidates), case.recommended


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--channels", type=int, nargs="+", default=[2, 16], choices=[2, 16])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    print(f"bayesnsi {bayesnsi.__version__} from {bayesnsi.__file__}")
    for n_channels in args.channels:
        signals, candidates, nsi = case_of(n_channels)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            select(signals, candidates[:1], nsi, EvidenceOptions(n_steps=100, n_burn=20))  # imports, warm caches
            times = []
            for _ in range(args.repeats):
                fresh = dataclasses.replace(signals)  # a new record, as a user's select meets it (nothing measured yet)
                t0 = time.perf_counter()
                select(fresh, candidates, nsi, EvidenceOptions())
                times.append(time.perf_counter() - t0)
        print(f"{n_channels:2d} channels, {len(candidates)} candidate(s): select best of {args.repeats} "
              f"{min(times):.2f} s (all: {', '.join(f'{t:.2f}' for t in times)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
