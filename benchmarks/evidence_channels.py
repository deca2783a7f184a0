"""Cost of the evidence per candidate and likelihood with 2 and 16 output channels (issue 15, acceptance 4).

16 channels: the 16-DOF cantilever beam of docs/method.md §8 (``simulate_case("beam")``, 100 s
at 1 kHz = 1e5 samples, 1 % noise) with all 16 DOFs measured and its true model {x13², x13³}
identified with block rows i = 10, order n = 32 (as measured in the issue); 2 channels: the
two-DOF case (1000 s at 100 Hz = 1e5 samples, 1 % noise, model 1, paper settings). Then
:func:`bayesnsi.evidence.candidate_evidence` is timed at default settings (innovations residual,
32 walkers or 2 x parameters + 2, 1500 steps) for each likelihood alone, then for the default
pair (AR(1) + white). Columns: seconds in the residual and its affine reconstruction (shared by
the likelihoods of a candidate), emcee, bridge + Laplace, arviz summary (R-hat, ESS, HDI, MCSE
of every parameter), and in all; the parameters sampled; Monte-Carlo error and bridge - Laplace
[nat]. Target: at most 1 s per candidate and likelihood.

Run::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/evidence_channels.py
"""

from __future__ import annotations

import dataclasses
import platform
import time
import warnings

import numpy as np

from bayesnsi.evidence import candidate_evidence
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.simulate.reference import case_setup, run_setup

SETTINGS = {16: ("beam", 100.0, tuple(range(1, 17)), NSIOptions(block_rows=10, order=32), 2),
            2: ("two-dof", 1000.0, (1, 2), None, 0)}  # None: the case's recommended settings (paper)


def identified(n_channels: int, seed: int = 0):
    """Simulated beam record with ``n_channels`` outputs and the true model identified on it."""
    name, duration, outputs, nsi, true_index = SETTINGS[n_channels]
    setup = dataclasses.replace(case_setup(name, duration=duration), output_dofs=outputs)
    (case,) = run_setup(setup, [seed], 1.0)
    candidate = case.candidates[true_index]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = identify(case.signals, candidate, nsi or case.recommended)
    return case.signals, result, candidate


def timed(signals, result, candidate, options):
    """Wall time of candidate_evidence and the primary likelihood's result."""
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = candidate_evidence(result, signals, options, np.random.SeedSequence(0), candidate, warn=False)
    return time.perf_counter() - t0, out


def main() -> int:
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}; N = 1e5 samples")
    head = (f"{'l':>3} {'likelihood':>12} {'params':>6} | {'residual':>8} {'emcee':>6} {'bridge':>6} {'summary':>7} "
            f"{'total s':>7} | {'SE nat':>7} {'br-lap':>7}")
    print(head)
    print("-" * len(head))
    for n_channels in (2, 16):
        signals, result, candidate = identified(n_channels)
        timed(signals, result, candidate, EvidenceOptions(likelihood="white", compare=()))  # warm caches/imports
        for likelihood in ("white", "ar1"):
            seconds, out = timed(signals, result, candidate, EvidenceOptions(likelihood=likelihood, compare=()))
            ev = out[likelihood]
            s = ev.settings
            inner = s["time_sampling_s"] + s["time_evidence_s"] + s["time_summary_s"]
            print(f"{n_channels:>3} {likelihood:>12} {ev.posterior.samples.shape[-1]:>6} | {seconds - inner:8.2f} "
                  f"{s['time_sampling_s']:6.2f} {s['time_evidence_s']:6.2f} {s['time_summary_s']:7.2f} "
                  f"{seconds:7.2f} | "
                  f"{ev.log_evidence_se:7.4f} {ev.log_evidence - ev.laplace_log_evidence:+7.4f}")
        seconds, _ = timed(signals, result, candidate, EvidenceOptions())
        print(f"{n_channels:>3} {'ar1 + white':>12} {'':>6} | {'':>8} {'':>6} {'':>6} {'':>7} {seconds:7.2f} |"
              "  (default: both likelihoods of one candidate)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
