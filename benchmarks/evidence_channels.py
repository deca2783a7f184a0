"""Cost of the evidence per candidate and likelihood with 2 and 16 output channels.

16 channels: the 16-DOF cantilever beam of docs/method.md §8 (``simulate_case("beam")``, 100 s
at 1 kHz = 1e5 samples, 1 % noise) with all 16 DOFs measured and its true model {x13², x13³}
identified with block rows i = 10, order n = 32; 2 channels: the
two-DOF case (1000 s at 100 Hz = 1e5 samples, 1 % noise, model 1, paper settings). For each
likelihood the evidence is computed on the same innovations residual by the collapsed estimator
(noise levels and AR coefficients integrated out, the coefficients sampled by emcee; docs/method.md
§6, Eq. 6.4) and by the joint estimator (emcee over every parameter), at default settings (32 walkers
or 2 x sampled parameters + 2, 1500 steps; the collapsed run is shortened where emcee's independence
move mixes well: the run that happened is printed below the table). Columns: seconds in the residual and its
affine reconstruction plus priors (shared by the likelihoods of a candidate), sampling, bridge +
Laplace, summary (R-hat, ESS, HDI, MCSE), the evidence in all (statistics included, residual not);
the parameters sampled; Monte-Carlo error, bridge - Laplace and collapsed - joint log Z [nat].
Then :func:`bayesnsi.evidence.candidate_evidence` at default settings (residual once, AR(1) and
white; best of 3 runs: the machine is shared; given the open-loop reconstruction, which ``select``
computes for the NRMSE anyway), for the first candidate of a ``select`` (on a fresh copy of the record)
and for each further one (the record's measured noise levels are kept with it). Target: at most 1 s
per candidate and likelihood. Last, the adequacy check of the candidate
(:func:`bayesnsi.checks.adequacy.model_checks`: open-loop residual, two noise draws through the model
for the yardstick, the bands), which ``select`` runs once per candidate.

Run::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/evidence_channels.py
"""

from __future__ import annotations

import dataclasses
import platform
import time
import warnings

import numpy as np

from bayesnsi.evidence import candidate_affine, candidate_evidence, candidate_priors, marginal_evidence
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


def timed(signals, result, candidate, options, cold: bool = True):
    """Wall time of candidate_evidence (given the open-loop reconstruction select has computed) and its results.

    ``cold``: on a fresh copy of the record, as for the first candidate of a ``select``; otherwise on
    ``signals`` as they are, whose measured noise levels an earlier candidate has computed (they are
    kept with the record: :func:`bayesnsi.nsi._noise.measured_noise_std`).
    """
    signals = dataclasses.replace(signals) if cold else signals
    reconstruction = result.reconstruct(signals)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = candidate_evidence(result, signals, options, np.random.SeedSequence(0), candidate, warn=False,
                                 reconstruction=reconstruction)
    return time.perf_counter() - t0, out


def estimator_rows(signals, result, candidate, likelihood: str):
    """The evidence by the collapsed estimator (default) and by the joint one it replaced, on the same statistics."""
    signals = dataclasses.replace(signals)  # a fresh copy: its noise levels measured again (first candidate)
    t0 = time.perf_counter()
    affine = candidate_affine(result, signals, EvidenceOptions().residual)
    priors = candidate_priors(result, signals, affine, EvidenceOptions(), candidate)
    t_residual = time.perf_counter() - t0
    q, l = len(affine.names), affine.measured.shape[1]
    out = {}
    for collapse in (True, False):
        ar = 0 if likelihood == "white" else 1
        n_params = q if collapse else q + l * (1 + ar)
        walkers = max(32, 2 * n_params + 2)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ev = marginal_evidence(affine, priors, likelihood, rng=np.random.default_rng(0),
                                   n_walkers=walkers + walkers % 2, warn=False, collapse=collapse)
        out[collapse] = (time.perf_counter() - t0, n_params, ev)
    return t_residual, out


def main() -> int:
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}; N = 1e5 samples")
    print("estimator: collapsed = noise levels and AR coefficients integrated out, the coefficients sampled "
          "(docs/method.md §6, Eq. 6.4); joint = emcee over all parameters (the earlier default)")
    head = (f"{'l':>3} {'likelihood':>10} {'estimator':>9} {'params':>6} | {'residual':>8} {'sample':>6} {'bridge':>6} "
            f"{'summary':>7} {'evid. s':>7} | {'SE nat':>7} {'br-lap':>7} {'new-old':>8}")
    print(head)
    print("-" * len(head))
    pairs, checks, runs = {}, {}, []
    for n_channels in (2, 16):
        signals, result, candidate = identified(n_channels)
        timed(signals, result, candidate, EvidenceOptions(likelihood="white", compare=()))  # warm caches/imports
        for likelihood in ("white", "ar1"):
            t_residual, rows = estimator_rows(signals, result, candidate, likelihood)
            new = rows[True][2].log_evidence
            runs.append(f"{n_channels:>3} {likelihood:>5} collapsed: {rows[True][2].sampler.describe()}")
            for collapse in (True, False):
                seconds, n_params, ev = rows[collapse]
                s = ev.settings
                print(f"{n_channels:>3} {likelihood:>10} {'collapsed' if collapse else 'joint':>9} {n_params:>6} | "
                      f"{t_residual:8.2f} {s['time_sampling_s']:6.2f} {s['time_evidence_s']:6.2f} "
                      f"{s['time_summary_s']:7.2f} {seconds:7.2f} | {ev.log_evidence_se:7.4f} "
                      f"{ev.log_evidence - ev.laplace_log_evidence:+7.4f} {new - ev.log_evidence:+8.4f}")
        pairs[n_channels] = [min(timed(signals, result, candidate, EvidenceOptions(), cold)[0] for _ in range(3))
                             for cold in (True, False)]
        checks[n_channels] = min(timed_checks(signals, result) for _ in range(3))
    print("\nsamplers that ran:")
    print("\n".join(runs))
    print("\ncandidate_evidence at default settings (residual once, then ar1 and white; collapsed estimator; "
          "best of 3 runs); first candidate of a select (the record's noise levels measured) and each further one:")
    for n_channels, (first, further) in pairs.items():
        print(f"{n_channels:>3} channels: first {first:5.2f} s for both likelihoods, "
              f"{first / 2:5.2f} s per likelihood; further {further:5.2f} s, {further / 2:5.2f} s per likelihood")
    print("\nmodel_checks of the candidate (open-loop residual, two noise draws for the yardstick, bands; best of 3):")
    for n_channels, seconds in checks.items():
        print(f"{n_channels:>3} channels: {seconds:5.2f} s")
    return 0


def timed_checks(signals, result) -> float:
    """Wall time of the adequacy check of one candidate (bayesnsi.checks.adequacy.model_checks), as select runs it."""
    from types import SimpleNamespace

    from bayesnsi.checks.adequacy import model_checks

    t0 = time.perf_counter()
    model_checks([SimpleNamespace(name="candidate", result=result, intervals=None)], signals)
    return time.perf_counter() - t0


if __name__ == "__main__":
    raise SystemExit(main())
