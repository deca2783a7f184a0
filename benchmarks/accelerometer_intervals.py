"""Honest intervals and adequacy for accelerometer data on non-periodic records (docs/method.md §11).

A cubic two-DOF chain (x1³ at DOF 1, k3 = 1e5 N/m³) driven at
DOF 2 by a band-limited random force (1-30 Hz, 5 N rms, 60 s at 100 Hz from rest: no period) is
measured by two accelerometers with white noise of 2 % of each channel's std, written to a CSV
file and loaded with ``[data] integrate = { band_hz = [1.0, 45.0] }`` (frequency method), as a
user would. Per seed the true candidate (x1³) and a wrong one (x2³ at DOF 2) are identified with
default settings (order 4) and their noise-replicate 95 % intervals computed twice:

* before: ``trim_edges = false`` (every sample kept, as before) and the signals without
  ``acceleration_noise`` - the replicates add white noise at the level high-order differences read
  on the integrated displacement, the adequacy noise is that level, no widening;
* after: the same samples, with the accelerometers' white noise (estimated on the accelerations
  before integration) integrated by the same recipe (``bayesnsi.noise.integrated``);
* trimmed: the default now, ``trim_edges = true`` (2/(taper f_lo) = 4 s dropped at each end, where
  the integrated motion misses the acceleration outside the record), with that noise.

The table gives, over the seeds, the coverage of the truth by the true candidate's 95 % intervals
(k3, f1, f2, ζ1, ζ2; the truth of the modes is the underlying linear system's), their mean width
over 2 × 1.96 × the seed-to-seed sd of the estimates, before and after the widening of inadequate
candidates, the adequacy ratio (open-loop residual rms over the noise std, largest channel) of the
true and the wrong candidate, the residual at the record's edges over the interior's, how often the
true candidate has the larger evidence (AR(1)), and the estimated accelerometer noise over the
simulated one.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/accelerometer_intervals.py --seeds 30
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/accelerometer_intervals.py --seeds 30 --excitation sweep
    .venv/bin/python benchmarks/accelerometer_intervals.py --seeds 3     # quick check
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy (shared 2-core machine)

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi.checks.adequacy import model_checks
from bayesnsi.io import load_config, load_signals  # noqa: E402
from bayesnsi.models import CandidateModel, Term  # noqa: E402
from bayesnsi.options import EvidenceOptions, NSIOptions  # noqa: E402
from bayesnsi.run import run_candidates  # noqa: E402
from bayesnsi.simulate import (  # noqa: E402
    band_limited_gaussian,
    chain_system,
    from_samples,
    modal_parameters,
    simulate_response,
)
from bayesnsi.uncertainty import widen_inadequate  # noqa: E402

FS, DURATION, FORCE_BAND, RMS, NOISE = 100.0, 60.0, (1.0, 30.0), 5.0, 0.02
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
F_TRUE, Z_TRUE = modal_parameters(*MCK)
K3 = 1e5
TRUE = CandidateModel("x1 cubic", (Term("x1**3", 1),))
WRONG = CandidateModel("x2 cubic", (Term("x2**3", 2),))
BAND = (1.0, 45.0)
NSI = NSIOptions(order=4)
LABELS = ("before", "after", "trimmed")
EXCITATION = {"kind": "random"}
CONFIG = """[data]
file = "record.csv"
time_column = "t"
inputs = {{ f = 2 }}
accelerations = {{ a1 = 1, a2 = 2 }}
integrate = {{ band_hz = [{lo}, {hi}] }}
[[candidates]]
name = "x1 cubic"
terms = [{{ expr = "x1**3", at = 1 }}]
"""


def simulate(seed: int, folder: Path, duration: float = DURATION, trim: bool = False) -> tuple[Path, np.ndarray]:
    """Write the record of ``seed`` (CSV + config); the simulated accelerometer noise std per channel."""
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    if EXCITATION["kind"] == "sweep":  # linear sweep over the force band, random phase, 1 s tapers at the ends
        t = np.arange(n) / FS
        f0, f1 = FORCE_BAND
        phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * duration)) + rng.uniform(0, 2 * np.pi)
        taper = np.minimum(1.0, np.minimum(t, t[-1] - t) / 1.0)
        sweep = np.sin(phase) * (0.5 - 0.5 * np.cos(np.pi * taper))
        force = from_samples(sweep * RMS / sweep.std(), FS, 8, FORCE_BAND)
    else:
        force = band_limited_gaussian(n, FS, RMS, rng, oversample=8, band_hz=FORCE_BAND)
    response = simulate_response(*MCK, [2], force.fine, FS * 8, 8, [Term("x1**3", 1)], [K3])
    acc = response.acceleration
    std = NOISE * acc.std(axis=0)
    noisy = acc + std * rng.standard_normal(acc.shape)
    t = np.arange(n) / FS
    table = np.column_stack([t, response.force[:, 0], noisy])
    folder.mkdir(parents=True, exist_ok=True)
    np.savetxt(folder / "record.csv", table, delimiter=",", header="t,f,a1,a2", comments="")
    (folder / "config.toml").write_text(CONFIG.format(lo=BAND[0], hi=BAND[1]).replace(
        "] }", "], trim_edges = false }"))
    (folder / "trimmed.toml").write_text(CONFIG.format(lo=BAND[0], hi=BAND[1]))  # the default
    return folder / "config.toml", std


def parameters(intervals, f_true) -> tuple[np.ndarray, np.ndarray]:
    """Estimates and 95 % intervals of k3, f1, f2, ζ1, ζ2: each true mode matched to the nearest identified one."""
    rows = [intervals.coefficients[0]]
    freqs = np.array([p.estimate for p in intervals.frequencies])
    for f in f_true:
        k = int(np.argmin(np.abs(freqs - f))) if len(freqs) else -1
        rows.append(intervals.frequencies[k] if k >= 0 and abs(freqs[k] - f) < 0.1 * f else None)
    rows += [None if r is None else intervals.damping_ratios[list(intervals.frequencies).index(r)] for r in rows[1:]]
    est = np.array([np.nan if p is None else p.estimate for p in rows], dtype=float)
    ci = np.array([(np.nan, np.nan) if p is None else p.ci95 for p in rows], dtype=float)
    return est, ci


def one_seed(seed: int, folder: Path, evidence: EvidenceOptions) -> dict:
    config_path, true_std = simulate(seed, folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        after = load_signals(load_config(config_path))
        before = replace(after, acceleration_noise=None)
        trimmed = load_signals(load_config(config_path.parent / "trimmed.toml"))
        out = {"noise_over_truth": np.asarray(after.acceleration_noise.acceleration_std) / true_std}
        for label, signals in (("before", before), ("after", after), ("trimmed", trimmed)):
            outcomes = run_candidates(signals, [TRUE, WRONG], NSI, evidence)
            checks = model_checks(outcomes, signals)
            est, ci = parameters(outcomes[0].intervals, F_TRUE)
            outcomes, checks = widen_inadequate(outcomes, checks, signals)
            wide = parameters(outcomes[0].intervals, F_TRUE)[1]
            out[label] = {"est": est, "ci": ci, "wide": wide, "true_ratio": checks[TRUE.name].noise_ratio,
                          "wrong_ratio": checks[WRONG.name].noise_ratio, "widened": outcomes[0].intervals.widening,
                          "wrong_widened": outcomes[1].intervals.widening,
                          "edge_ratio": checks[TRUE.name].edge_ratio,
                          "true_wins": outcomes[0].evidences[evidence.likelihood].log_evidence
                          > outcomes[1].evidences[evidence.likelihood].log_evidence}
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--replicates", type=int, default=16)
    parser.add_argument("--excitation", choices=("random", "sweep"), default="random",
                        help="band-limited random force (default) or a linear sweep over the same band")
    args = parser.parse_args()
    EXCITATION["kind"] = args.excitation
    truth = np.concatenate([[K3], F_TRUE, Z_TRUE])
    names = ["k3", "f1", "f2", "zeta1", "zeta2"]
    evidence = EvidenceOptions(interval="noise", n_replicates=args.replicates)
    runs, start = [], time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            runs.append(one_seed(seed, Path(tmp) / f"seed{seed}", evidence))
    wall = time.perf_counter() - start
    noise_ratio = np.array([r["noise_over_truth"] for r in runs])
    print(f"{args.excitation} force, {args.seeds} seeds, {args.replicates} replicates, {wall:.0f} s; estimated / "
          f"simulated accelerometer noise: mean {noise_ratio.mean():.3f}, "
          f"range {noise_ratio.min():.3f}-{noise_ratio.max():.3f}")
    print(f"\n{'':8}{'parameter':<10}{'cov 95 %':>10}{'width/scatter':>15}{'centre bias/sd':>16}"
          f"{'widened: cov 95 %':>19}{'width/scatter':>15}{'scatter/truth':>15}")
    for label in LABELS:
        est = np.array([r[label]["est"] for r in runs])
        scatter = np.nanstd(est, axis=0, ddof=1)
        cols = []
        for key in ("ci", "wide"):
            ci = np.array([r[label][key] for r in runs])
            inside = (ci[:, :, 0] <= truth) & (truth <= ci[:, :, 1])
            found = np.isfinite(ci[:, :, 0])
            cols.append((inside.sum(axis=0) / found.sum(axis=0),
                         np.nanmean(ci[:, :, 1] - ci[:, :, 0], axis=0) / (2 * 1.96 * scatter)))
        bias = (np.nanmean(est, axis=0) - truth) / scatter
        for j, name in enumerate(names):
            print(f"{label:8}{name:<10}{100 * cols[0][0][j]:>9.0f}%{cols[0][1][j]:>15.3g}{bias[j]:>16.2f}"
                  f"{100 * cols[1][0][j]:>18.0f}%{cols[1][1][j]:>15.3g}{100 * scatter[j] / truth[j]:>14.2f}%")
    print(f"\n{'':8}{'adequacy ratio: true (median, range)':<40}{'wrong (median, range)':<30}")
    for label in LABELS:
        t = np.array([r[label]["true_ratio"] for r in runs])
        w = np.array([r[label]["wrong_ratio"] for r in runs])
        print(f"{label:8}{f'{np.median(t):.3g} ({t.min():.3g}-{t.max():.3g})':<40}"
              f"{f'{np.median(w):.3g} ({w.min():.3g}-{w.max():.3g})':<30}")
    for label in LABELS:
        t = np.array([r[label]["true_ratio"] for r in runs])
        w = np.array([r[label]["wrong_ratio"] for r in runs])
        widened = np.array([r[label]["widened"] > 1 for r in runs])
        edges = np.array([np.nan if r[label]["edge_ratio"] is None else r[label]["edge_ratio"] for r in runs])
        wins = np.mean([r[label]["true_wins"] for r in runs])
        edge_text = "-" if np.all(np.isnan(edges)) else f"{np.nanmedian(edges):.3g} ({np.nanmin(edges):.3g}-" \
            f"{np.nanmax(edges):.3g})"
        print(f"{label}: true model adequate (ratio <= 1.3) on {np.mean(t <= 1.3):.0%} of the seeds, wrong one on "
              f"{np.mean(w <= 1.3):.0%}; true model's intervals widened on {widened.mean():.0%}; edge ratio "
              f"{edge_text}; larger evidence for the true model on {wins:.0%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
