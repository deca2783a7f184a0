"""The quality index judged against the model's misfit: true, wrong and null effects side by side.

For each record, each effect is added to the model the loop would check it against and identified
with the record's NSI settings; the table gives its log Bayes factor (Laplace), its quality index
|Im|/|Re|, the misfit ratio κ and the memory resolution M of :func:`bayesnsi.loop.quality.misfit_reading`,
the verdict of the quality check (:func:`bayesnsi.loop.quality.quality_check`: "index" below
``max_imag_ratio``, "unresolved" passed as not resolved against the misfit, "fails") and, where the
record has held-out data, the ratio of each held-out error after / before (never used by the loop).
The null effects are a linear spring and a linear damper at the location of the interface: their true
coefficient is 0, so what they pick up is the linear part's model error.

* **F-16** (measured, ``../shared/data/f16``): level 5 (or ``--f16-level 3``) against the linear model;
  held-out errors on the other full level and the three random-odd records.
* **GVT twin** (simulated, known truth: a 12-DOF chain whose joint between sensors 7 and 8 holds
  friction 0.1 tanh(v/0.002) N and a cubic spring 2e7 N/m³; ``workflows/gvt.py``): 1 N, against the
  linear model and against the model holding the friction the loop adds first; held out: the other
  realisation and the other levels.
* **Cubic pair, modes missing** (simulated, known truth: :func:`bayesnsi.simulate.undeclared_case`
  "cubic-pair", 1 % noise, seeds 0-2; identified at order 6, the truth, and at order 2, two of its three
  modes missing from the linear part).

Run: ``OMP_NUM_THREADS=1 .venv/bin/python benchmarks/quality_misfit.py [--skip f16 gvt cubic]``
(about a minute of CPU for the F-16, two for the twin).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import tempfile  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bayesnsi.checks.validation import validate  # noqa: E402
from bayesnsi.io import load_config, load_signals, load_validation  # noqa: E402
from bayesnsi.loop.quality import misfit_reading, quality_check  # noqa: E402
from bayesnsi.loop.scoring import laplace_score  # noqa: E402
from bayesnsi.models import CandidateModel, Term, clearance_expression  # noqa: E402
from bayesnsi.nsi import identify  # noqa: E402
from bayesnsi.options import EvidenceOptions, LoopOptions  # noqa: E402
from bayesnsi.simulate import gvt_records, undeclared_case  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
F16 = ROOT / "workflows" / "f16"
LOOP, EVIDENCE = LoopOptions(), EvidenceOptions(residual=LoopOptions().residual, compare=())


def _identify(signals, candidate, nsi):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify(signals, candidate, nsi)


def _row(name, note, base, base_z, trial, signals, segments=None, before=None) -> str:
    """One table row: the effect (last term of ``trial``) against ``base``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        z = laplace_score(trial, signals, EVIDENCE)[0]
        reading = misfit_reading(trial, signals)
        held = "" if segments is None else " | ".join(
            "diverged" if s.nrmse is None else f"{s.nrmse / before[s.name]:.2f}" for s in validate(trial, segments))
    q = trial.coefficients[-1].imag_ratio
    check, unresolved = quality_check(q, LOOP.max_imag_ratio, EVIDENCE.max_noise_ratio, reading)
    verdict = "unresolved" if unresolved else ("index" if check.passed else "fails")
    return (f"| {name} | {note} | {z - base_z:.4g} | {q:.3g} | {reading.misfit_ratio:.3g} | {reading.resolution:.3g} | "
            f"{verdict} |" + (f" {held} |" if held else ""))


def _header(held=()) -> None:
    print("| effect | truth / role | log BF | quality index | κ | M | quality check |"
          + "".join(f" {h} |" for h in held))
    print("| --- " * (7 + len(held)) + "|")


def f16(level: int) -> None:
    config = load_config(F16 / f"level{level}.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        signals, segments = load_signals(config), load_validation(config)
    linear = _identify(signals, CandidateModel("linear", ()), config.nsi)
    nsi = config.nsi.replace(order=linear.order)
    before = {s.name: s.nrmse for s in validate(linear, segments)}
    z0 = laplace_score(linear, signals, EVIDENCE)[0]
    x = np.asarray(signals.displacement)
    sd = float(np.std(x[:, 1] - x[:, 2]))
    effects = [
        (clearance_expression("(x2-x3)", 0.25 * sd), "clearance, gap 0.25 std (the former refinement's choice)"),
        (clearance_expression("(x2-x3)", 0.5 * sd), "clearance, gap 0.5 std"),
        (clearance_expression("(x2-x3)", sd), "clearance, gap 1 std"),
        ("(x2-x3)*abs(x2-x3)", "x|x|"), ("(x2-x3)**3", "cubic"), ("(v2-v3)*abs(v2-v3)", "v|v|"),
        ("(v2-v3)**3", "v³"), ("x2-x3", "null: linear spring"), ("v2-v3", "null: linear damper"),
    ]
    print(f"\n## F-16, full multisine level {level} (measured), against the linear model (order {linear.order})")
    print("held out: NRMSE after / before (" + ", ".join(before) + ")")
    _header(before)
    for expr, note in effects:
        trial = _identify(signals, CandidateModel("trial", (Term(expr, (2, 3)),)), nsi)
        print(_row(expr if "abs((" not in expr else "clearance (x2-x3)", note, linear, z0, trial, signals, segments,
                   before))


def gvt() -> None:
    spec = importlib.util.spec_from_file_location("gvt_workflow", ROOT / "workflows" / "gvt.py")
    workflow = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(workflow)
    records = gvt_records(levels=workflow.LEVELS, n_realisations=2, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        config = load_config(workflow.write(records, Path(tmp))[1])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            signals, segments = load_signals(config), load_validation(config)
    linear = _identify(signals, CandidateModel("linear", ()), config.nsi)
    nsi = config.nsi.replace(order=linear.order)
    friction = Term("tanh((v7-v8)/0.00909)", (7, 8))
    with_friction = _identify(signals, CandidateModel("friction", (friction,)), nsi)
    effects = [("(x7-x8)**3", "true (2e7)"), (clearance_expression("(x7-x8)", 0.000627498), "stiffening look-alike"),
               ("(x7-x8)*abs(x7-x8)", "stiffening look-alike"), ("(v7-v8)*abs(v7-v8)", "wrong"),
               ("x7-x8", "null: linear spring"), ("v7-v8", "null: linear damper")]
    for base, label in ((linear, "the linear model"), (with_friction, "linear + tanh((v7-v8)/0.00909)")):
        before = {s.name: s.nrmse for s in validate(base, segments)}
        z0 = laplace_score(base, signals, EVIDENCE)[0]
        print(f"\n## GVT twin 1 N (simulated), against {label}")
        print("held out: NRMSE after / before (" + ", ".join(before) + ")")
        _header(before)
        for expr, note in effects:
            trial = _identify(signals, base.candidate.with_term(Term(expr, (7, 8))), nsi)
            print(_row(expr if "abs((" not in expr else "clearance (x7-x8)", note, base, z0, trial, signals, segments,
                       before))


def cubic(seeds=(0, 1, 2)) -> None:
    effects = [("(x1-x2)**3", "true (2e5)"), ("(x1-x2)*abs(x1-x2)", "look-alike"), ("(v1-v2)*abs(v1-v2)", "wrong"),
               ("x1-x2", "null: linear spring"), ("v1-v2", "null: linear damper")]
    for seed, order in [(s, o) for s in seeds for o in (6, 2)]:
        case = undeclared_case("cubic-pair", seed, 1.0)
        nsi = case.nsi.replace(order=order)
        base = _identify(case.signals, case.declared, nsi)
        z0 = laplace_score(base, case.signals, EVIDENCE)[0]
        print(f"\n## Cubic pair (simulated, seed {seed}), linear model at order {order}")
        _header()
        for expr, note in effects:
            trial = _identify(case.signals, case.declared.with_term(Term(expr, (1, 2))), nsi)
            print(_row(expr, note, base, z0, trial, case.signals))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip", nargs="*", default=[], choices=["f16", "gvt", "cubic"])
    parser.add_argument("--f16-level", type=int, default=5, choices=[1, 3, 5])
    args = parser.parse_args(argv)
    if "cubic" not in args.skip:
        cubic()
    if "f16" not in args.skip and (ROOT.parent / "shared" / "data" / "f16").is_dir():
        f16(args.f16_level)
    if "gvt" not in args.skip:
        gvt()


if __name__ == "__main__":
    main()
