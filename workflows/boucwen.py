"""The Bouc-Wen benchmark (simulated with the published settings): the loop finds the hysteresis; test errors.

Usage::

    .venv/bin/python workflows/boucwen.py --out out/boucwen [--domain frequency] [--seed 0]

The nonlinear-identification benchmark of Noël and Schoukens ("Hysteretic benchmark with a dynamic
nonlinearity", Workshop on Nonlinear System Identification Benchmarks, Brussels 2016;
nonlinearbenchmark.org): m = 2 kg, c = 10 N s/m, k = 5e4 N/m and the hysteretic force
z' = α y' - β (γ |y'| z + δ y' |z|), α = 5e4 N/m, β = 1e3 1/m, γ = 0.8, δ = -1.1 (ν = 1), i.e.
``5e4 * boucwen(x1, beta=800, gamma=-1100)`` in bayesnsi's grammar (docs/method.md §12). The
records are simulated by :func:`bayesnsi.simulate.simulate_hysteretic_response` (RK4 of [y, y', z]
with step 1/7500 s: ``--decimation 20`` fine samples per 750 Hz sample) with the published
settings; the benchmark's own test files are not read:

* estimation: a random-phase multisine on every line of 5-150 Hz, rms 50 N, 8192 samples per period
  at 750 Hz, 6 periods from rest of which the first is dropped, white output noise of 8e-3 mm rms;
* validation: a second realisation (new phases), 2 steady periods, same noise (report only);
* test multisine: a third realisation, one steady period, noise-free (simulated over one transient
  period first, as the benchmark's file is in steady state);
* test sine sweep: 40 N from rest, the frequency rising from 20 Hz at 10 Hz/min, 153 000 samples
  (204 s), noise-free.

Models, all identified by NSI on the estimation data (``[nsi] block_rows = 20, order = 2``): linear;
the static candidates of ``benchmarks/bouc_wen.py``; the loop from the linear model with
the default dictionary without Bouc-Wen elements (the best static model the loop builds); the loop
from the linear model with the default dictionary; and the true structure (the Bouc-Wen term with
the published shape). Test errors are RMS simulation errors [m] (the benchmark's e_RMS). Writes
``OUT/boucwen.md``, ``OUT/results.json``, the records as the benchmark ships them (``uest.csv``,
``yest.csv``, ``uval.csv``, ``yval.csv``) and ``OUT/bw.toml`` for ``bayesnsi select`` / ``diagnose``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from bayesnsi import Signals
from bayesnsi.io import atomic_write_json, atomic_write_text, prepare_output_dir, to_jsonable, versions
from bayesnsi.loop import close_the_loop
from bayesnsi.models import CandidateModel, Term
from bayesnsi.models.dictionary import CLEARANCE, DEFAULT_EFFECT_TYPES, SMOOTH_FRICTION
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, LoopOptions, NSIOptions
from bayesnsi.simulate import multisine, simulate_hysteretic_response

FS, PERIOD, NOISE = 750.0, 8192, 8e-6  # Hz, samples, m (the benchmark's 8e-3 mm)
MASS, DAMPING, STIFFNESS, ALPHA = 2.0, 10.0, 5e4, 5e4
TRUE_TERM = "boucwen(x1, beta=800, gamma=-1100)"  # β γ = 800, β δ = -1100 1/m
SWEEP = (40.0, 20.0, 10.0 / 60.0, 153_000)  # amplitude [N], start [Hz], rate [Hz/s], samples
STATIC = {"cubic": ["x1**3"], "quadratic damping": ["v1*abs(v1)"], "Coulomb": ["sign(v1)"],
          "smoothed friction": ["tanh(v1/0.01)"], "cubic + Coulomb": ["x1**3", "sign(v1)"]}
# Published figures (RMS simulation error of polynomial nonlinear state-space models on a validation
# multisine of the same system and settings, Noël, Esfahani, Kerschen, Schoukens, "A nonlinear
# state-space approach to hysteresis identification", MSSP 84 (2017) 171-184, arXiv:1610.09138;
# quoted in dB re 1 m): polynomial degrees -> dB
PUBLISHED_DB = {"PNLSS degree 2": -85.32, "PNLSS degrees 2-3": -90.35, "PNLSS degrees 2-3-4-5": -94.87,
                "PNLSS degrees 2-7": -97.96, "PNLSS degrees 3-5-7": -98.32}

CONFIG = """# The Bouc-Wen benchmark system, simulated with the published settings (workflows/boucwen.py)
seed = 0
[data]
files = {{ u = "uest.csv", y = "yest.csv" }}
fs = 750.0
inputs = {{ u = 1 }}
outputs = {{ y = 1 }}
units = {{ u = "N", y = "m" }}
period = 8192
[nsi]
block_rows = 20
order = 2
domain = "{domain}"
{candidates}
[[validation]]
name = "second realisation"
files = {{ u = "uval.csv", y = "yval.csv" }}
"""


def simulate(force_fine: np.ndarray, decimation: int) -> np.ndarray:
    """The benchmark system's displacement at 750 Hz for a force on the fine grid (from rest)."""
    response = simulate_hysteretic_response([[MASS]], [[DAMPING]], [[STIFFNESS]], [1], force_fine[:, None],
                                            FS * decimation, decimation, [Term(TRUE_TERM, 1)], [ALPHA])
    return response.displacement[:, 0]


def multisine_record(seed: int, periods: int, kept: int, noise: float, decimation: int) -> Signals:
    """``periods`` periods of a full multisine from rest; the last ``kept`` with white output noise."""
    force = multisine(PERIOD, FS, (5.0, 150.0), rms=50.0, rng=seed, kind="full", n_periods=periods,
                      oversample=decimation)
    y = simulate(force.fine[:, 0], decimation)[-kept * PERIOD :]
    y = y + noise * np.random.default_rng([seed, 1]).standard_normal(y.size)
    return Signals(force=force.samples[-kept * PERIOD :], displacement=y[:, None], fs=FS, input_dofs=(1,),
                   output_dofs=(1,), period=PERIOD)


def sweep_record(decimation: int) -> Signals:
    """The test sine sweep from rest (noise-free)."""
    amplitude, start, rate, samples = SWEEP
    t = np.arange((samples - 1) * decimation + 1) / (FS * decimation)
    fine = amplitude * np.sin(2 * np.pi * (start * t + 0.5 * rate * t**2))
    y = simulate(fine, decimation)
    return Signals(force=fine[::decimation, None], displacement=y[:, None], fs=FS, input_dofs=(1,), output_dofs=(1,))


def test_errors(result, tests: dict, nrmse: bool = False) -> dict:
    """RMS simulation error [m] (or the NRMSE) on each record, NaN where the simulation fails."""
    out = {}
    for name, signals in tests.items():
        try:
            if nrmse:  # a validation record of whole steady periods (harmonic balance on the frequency route)
                out[name] = float(result.reconstruct(signals, closed_loop=True).nrmse)
                continue
            if name == "multisine" and result.options.domain == "frequency":
                steady = Signals(force=signals.force[PERIOD:], displacement=signals.displacement[PERIOD:], fs=FS,
                                 input_dofs=(1,), output_dofs=(1,), period=PERIOD)
                error = steady.displacement - result.reconstruct(steady, closed_loop=True).predicted
            else:  # from rest; the multisine's first period is its transient
                record = Signals(force=signals.force, displacement=signals.displacement, fs=FS, input_dofs=(1,),
                                 output_dofs=(1,))
                error = record.displacement - result.reconstruct(record, closed_loop=True).predicted
                error = error[PERIOD:] if name == "multisine" else error
            out[name] = float(np.sqrt(np.mean(error**2)))
        except Exception as err:  # noqa: BLE001 - a model that diverges on a test record is reported, not fatal
            print(f"  {result.candidate.name} on the {name} test: {type(err).__name__}: {err}", file=sys.stderr)
            out[name] = float("nan")
    return out


def run(out: Path, domain: str, seed: int, decimation: int) -> dict:
    """Records, identifications, loops and test errors (module notes)."""
    t0 = time.perf_counter()
    estimation = multisine_record(seed + 1, 6, 5, NOISE, decimation)
    validation = multisine_record(seed + 2, 3, 2, NOISE, decimation)
    tests = {"multisine": multisine_record(seed + 3, 2, 2, 0.0, decimation), "sine sweep": sweep_record(decimation)}
    print(f"simulated the records ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    for name, signals in (("est", estimation), ("val", validation)):
        np.savetxt(out / f"u{name}.csv", signals.force[:, 0], fmt="%.10e")
        np.savetxt(out / f"y{name}.csv", signals.displacement[:, 0], fmt="%.10e")
    candidates = "".join(
        f'[[candidates]]\nname = "{name}"\nterms = [{", ".join(f"{{ expr = {e!r}, at = 1 }}" for e in terms)}]\n'
        .replace("'", '"') for name, terms in {"linear": [], **STATIC}.items())
    atomic_write_text(out / "bw.toml", CONFIG.format(domain=domain, candidates=candidates))
    nsi = NSIOptions(block_rows=20, order=2, domain=domain)
    evidence = EvidenceOptions(seed=seed)
    linear = CandidateModel(name="linear", terms=())
    models = {"linear": identify(estimation, linear, nsi)}
    for name, terms in STATIC.items():
        models[name] = identify(estimation, CandidateModel.from_terms(name, [(e, 1) for e in terms]), nsi)
    loops = {}
    static_types = (*DEFAULT_EFFECT_TYPES, CLEARANCE, SMOOTH_FRICTION)
    for label, options in (("loop without Bouc-Wen", LoopOptions(effects=static_types)), ("loop", LoopOptions())):
        t1 = time.perf_counter()
        loop = close_the_loop(estimation, linear, options, nsi=nsi, evidence=evidence)
        loops[label] = {"added": [s.term.name for s in loop.added], "seconds": time.perf_counter() - t1,
                        "coefficients": {c.term.name: float(np.real(c.value)) for c in loop.final.coefficients}}
        models[f"{label}: {' + '.join(loops[label]['added']) or 'nothing added'}"] = loop.final
        print(f"{label}: added {loops[label]['added']} ({loops[label]['seconds']:.0f} s)", file=sys.stderr)
    truth = CandidateModel.from_terms("true", [(TRUE_TERM, 1)])
    models["true structure (published shape)"] = identify(estimation, truth, nsi)
    rows = []
    for name, result in models.items():
        rows.append({"model": name, "estimation_nrmse": result.reconstruct(estimation).nrmse,
                     "validation_nrmse": test_errors(result, {"validation": validation}, nrmse=True)["validation"],
                     "test_rmse": test_errors(result, tests),
                     "coefficients": {c.term.name: float(np.real(c.value)) for c in result.coefficients}})
    return {"settings": {"domain": domain, "seed": seed, "decimation": decimation, "noise_m": NOISE,
                         "nsi": nsi.to_dict()}, "versions": versions(), "loops": loops, "models": rows,
            "test_rms_m": {name: float(np.std(s.displacement)) for name, s in tests.items()},
            "seconds": time.perf_counter() - t0}


def table(results: dict) -> str:
    """Markdown table: estimation and validation NRMSE, test RMS errors [m], published figures."""
    lines = ["| model | estimation NRMSE (open loop) | validation NRMSE (closed loop) | test multisine e_RMS [m] | "
             "test sine sweep e_RMS [m] |", "| --- | --- | --- | --- | --- |"]
    for row in results["models"]:
        tests = row["test_rmse"]
        lines.append(f"| {row['model']} | {row['estimation_nrmse']:.4f} | {row['validation_nrmse']:.4f} | "
                     f"{tests['multisine']:.3g} | {tests['sine sweep']:.3g} |")
    for name, db in PUBLISHED_DB.items():
        lines.append(f"| {name} (Noël et al. 2017, their validation multisine) | - | - | {10 ** (db / 20):.3g} | - |")
    rms = results["test_rms_m"]
    lines.append(f"| (rms of the test output itself) | - | - | {rms['multisine']:.3g} | {rms['sine sweep']:.3g} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--force", action="store_true", help="overwrite existing results")
    parser.add_argument("--domain", choices=("time", "frequency"), default="time", help="NSI route")
    parser.add_argument("--seed", type=int, default=0, help="seed of the multisine phases, the noise and the evidence")
    parser.add_argument("--decimation", type=int, default=20,
                        help="fine samples per 750 Hz sample (RK4 step 2/(750 d))")
    args = parser.parse_args(argv)
    out = prepare_output_dir(args.out, force=args.force)
    results = run(out, args.domain, args.seed, args.decimation)
    text = table(results)
    atomic_write_text(out / "boucwen.md", text)
    atomic_write_json(out / "results.json", to_jsonable(results))
    print(text)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
