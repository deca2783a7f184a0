"""Silverbox (measured): close the loop from the linear and from the cubic model (SPEC 7 and 8.4).

Usage::

    .venv/bin/python workflows/silverbox.py --out out/silverbox-loops

For each starting model ("linear", "cubic" of ``workflows/silverbox/silverbox.toml``) it runs
:func:`bayesnsi.loop.close_the_loop` on the estimation data (official split
[40650, 105712)), then reports for the model before and after the loop: the effects added, the
open-loop NRMSE and RMS error [mV] on the estimation data, and the closed-loop simulation RMS error
[mV] and NRMSE on the benchmark's three test sets (the first 50 samples fix the initial state;
test data are never used for any decision), beside the published reference figures of
the benchmark (Champneys et al. 2024) and of an independent prototype made before this package.
Writes ``OUT/silverbox_loops.md`` and ``OUT/results.json`` (atomically).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from bayesnsi.checks.validation import validate
from bayesnsi.io import (
    atomic_write_json,
    atomic_write_text,
    load_config,
    load_signals,
    load_validation,
    prepare_output_dir,
    to_jsonable,
    versions,
)
from bayesnsi.loop import close_the_loop
from bayesnsi.nsi import identify

CONFIG = Path(__file__).parent / "silverbox" / "silverbox.toml"
STARTS = ("linear", "cubic")
MV = 1e3

# RMS simulation error on the test sets [mV]: multisine / arrow full / arrow no extrapolation
REFERENCES = {
    "LSTM (Champneys et al. 2024)": (1.50, 2.68, 0.96),
    "GRU (Champneys et al. 2024)": (1.49, 2.80, 0.95),
    "OLSTM (Champneys et al. 2024)": (1.51, 2.38, 1.08),
    "vanilla RNN (Champneys et al. 2024)": (1.64, 4.88, 1.73),
    "MLP-FIR (Champneys et al. 2024)": (18.9, 20.2, 15.3),
    "prototype of the spec, {y², y³} (SPEC 8.4)": (0.38, 0.67, 0.35),
}


def model_errors(result, signals, segments) -> dict:
    """Open-loop errors on the estimation data and closed-loop errors on each test set."""
    rec = result.reconstruct(signals)
    return {
        "estimation_nrmse": rec.nrmse,
        "estimation_rmse_mv": float(rec.rmse[0] * MV),
        "tests": [
            {**v.to_dict(), "rmse_mv": None if v.rmse is None else v.rmse * MV} for v in validate(result, segments)
        ],
    }


def run_loops(config_path=CONFIG, starts=STARTS, quiet=False) -> dict:
    """Both loops and their before/after errors (see the module docstring)."""
    config = load_config(config_path)
    signals = load_signals(config)
    segments = load_validation(config)
    nsi = config.nsi
    evidence = config.evidence.replace(residual=config.loop.residual)  # the loop scores its own residual
    by_name = {c.name: c for c in config.candidates}
    out = {"settings": {"config": str(config_path), "nsi": nsi.to_dict(), "evidence": evidence.to_dict()}, "versions": versions(), "loops": []}
    for start in starts:
        t0 = time.perf_counter()
        loop = close_the_loop(signals, by_name[start], config.loop, nsi=nsi, evidence=evidence)
        before = identify(signals, by_name[start], nsi)
        entry = {
            "start": start,
            "added": [
                {"expr": s.term.expr.text, "at": s.term.at_value, "log_bayes_factor": s.log_bayes_factor,
                 "coefficient": s.coefficient}
                for s in loop.added
            ],
            "final_terms": [t.name for t in loop.final.terms],
            "before": model_errors(before, signals, segments),
            "after": model_errors(loop.final, signals, segments),
            "seconds": time.perf_counter() - t0,
        }
        out["loops"].append(entry)
        if not quiet:
            print(f"from {start}: added {[a['expr'] for a in entry['added']]} ({entry['seconds']:.0f} s)", file=sys.stderr)
    return out


def table(results: dict) -> str:
    """Markdown comparison table, ours before/after each loop and the references.

    Each cell is the RMS error [mV] with the NRMSE in parentheses: open-loop reconstruction on the
    estimation data, closed-loop simulation on the test sets (published figures: RMS only).
    """
    names = [t["name"] for t in results["loops"][0]["before"]["tests"]]
    head = "| model | estimation, open loop [mV] (NRMSE) | " + " | ".join(f"{n} [mV] (NRMSE)" for n in names) + " |"
    lines = [head, "|" + " --- |" * (2 + len(names))]
    for loop in results["loops"]:
        for when in ("before", "after"):
            errs = loop[when]
            label = f"loop from {loop['start']}, {when}"
            if when == "after":
                label += ": " + (", ".join(loop["final_terms"]) or "linear")
            cells = [
                f"{t['rmse_mv']:.2f} ({t['nrmse']:.4f})" if t["rmse_mv"] is not None else "failed" for t in errs["tests"]
            ]
            estimation = f"{errs['estimation_rmse_mv']:.2f} ({errs['estimation_nrmse']:.4f})"
            lines.append(f"| {label} | {estimation} | " + " | ".join(cells) + " |")
    for name, values in REFERENCES.items():
        lines.append(f"| {name} | - | " + " | ".join(f"{v:.2f}" for v in values) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--force", action="store_true", help="overwrite existing results")
    parser.add_argument("--config", default=str(CONFIG))
    args = parser.parse_args(argv)
    out = prepare_output_dir(args.out, force=args.force)
    results = run_loops(args.config)
    text = table(results)
    atomic_write_text(out / "silverbox_loops.md", text)
    atomic_write_json(out / "results.json", to_jsonable(results))
    print(text)
    for loop in results["loops"]:
        print(f"from {loop['start']}: added " + (", ".join(
            f"{a['expr']} at {a['at']} (coefficient {a['coefficient']:.4g}, log BF {a['log_bayes_factor']:.1f})"
            for a in loop["added"]) or "nothing"))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
