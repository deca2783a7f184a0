"""Free bodies with friction: screen ranks of the true effect and the loop over seeds.

Simulated carriage (``tests/_helpers/carriage.py``: M 95 kg, Fv 200 N s/m, Fc 20 N, offset -3 N, no
spring, PD position loop, 5 N force disturbance, 1 µm position noise; fs 200 Hz), seeds 0..S-1, and
the measured EMPS axis when its files are present. Per record: the rank of sign(v) in the
force-view screen (:mod:`bayesnsi.loop.screen_force`, used for free bodies) and in the
frequency-domain screen (used for structures, band 1.6 × the top of the identification band);
the loop from the linear model (default settings but ``refine_final`` off for the simulated
records): effects added, M, Fv (from the FRF) and Fc errors.

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/free_body.py [--seeds 5] [--duration 30]``
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bayesnsi.loop import close_the_loop, screen_effects  # noqa: E402
from bayesnsi.loop.screen_force import screen_effects_force  # noqa: E402
from bayesnsi.models import CandidateModel, default_gaps, effect_dictionary  # noqa: E402
from bayesnsi.nsi import identify  # noqa: E402
from bayesnsi.options import LoopOptions, NSIOptions  # noqa: E402
from bayesnsi.signals import Signals  # noqa: E402
from tests._helpers.carriage import FC, FV, MASS, free_body_record  # noqa: E402

EMPS = Path(__file__).resolve().parents[2] / "shared" / "data" / "emps" / "DATA_EMPS.mat"
EMPS_TRUTH = (95.1089, 203.5034, 20.3935)  # published IDIM-LS


def _ranks(signals, nsi) -> tuple[int, int]:
    linear = CandidateModel(name="linear", terms=())
    effects = effect_dictionary(signals.output_dofs, gaps={(1,): default_gaps(float(signals.displacement.std()))})
    force = [e.name for e, _ in screen_effects_force(signals, linear, effects)]
    start = identify(signals, linear, nsi)
    freq = [e.name for e, _ in screen_effects(signals, linear, effects, max_frequency_hz=1.6 * start.band_hz[1])]
    return force.index("sign(v)") + 1, freq.index("sign(v)") + 1


def _loop(signals, nsi, options, truth) -> str:
    loop = close_the_loop(signals, CandidateModel(name="linear", terms=()), options, nsi=nsi)
    added = [s.effect.name for s in loop.steps if s.accepted]
    (phys,) = loop.final.physical_parameters
    coefs = dict(zip((t.name for t in loop.final.terms), loop.final.coefficient_values))
    fc = coefs.get("sign(v1)@1", np.nan)
    m, fv, c = truth
    return (f"{','.join(added) or '-':<18} {100 * (phys.mass / m - 1):+6.1f} {100 * (phys.damping / fv - 1):+6.1f} "
            f"{100 * (fc / c - 1):+6.1f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--duration", type=float, default=30.0, help="simulated record length [s]")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    print(f"{'record':<22} {'rank force':>10} {'rank freq':>9}  {'added':<18} {'M %':>6} {'Fv %':>6} {'Fc %':>6}")
    for seed in range(args.seeds):
        q, tau = free_body_record(seed=seed, duration=args.duration)
        signals = Signals(force=(tau - tau.mean())[:, None], displacement=(q - q.mean())[:, None], fs=200.0,
                          input_dofs=(1,), output_dofs=(1,))
        nsi = NSIOptions(block_rows=20)
        rf, rq = _ranks(signals, nsi)
        row = _loop(signals, nsi, LoopOptions(refine_final=None), (MASS, FV, FC))
        print(f"{'carriage seed ' + str(seed):<22} {rf:>10} {rq:>9}  {row}")
    if EMPS.exists():
        import scipy.io

        data = scipy.io.loadmat(EMPS)
        q, tau = data["qm"][:, 0], (data["gtau"] * data["vir"])[:, 0]
        signals = Signals(force=(tau - tau.mean())[:, None], displacement=(q - q.mean())[:, None], fs=1000.0,
                          input_dofs=(1,), output_dofs=(1,))
        rf, rq = _ranks(signals, NSIOptions())
        print(f"{'EMPS (measured)':<22} {rf:>10} {rq:>9}  {_loop(signals, NSIOptions(), LoopOptions(), EMPS_TRUTH)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
