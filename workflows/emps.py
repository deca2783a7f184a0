"""EMPS positioning axis (measured free body with friction): select, loop from linear, force errors.

Usage::

    .venv/bin/python workflows/emps.py --out out/emps

Reads ``workflows/emps/emps.toml`` (the data at ``../shared/data/emps`` relative to the repository:
``DATA_EMPS.mat`` for estimation, ``DATA_EMPS_PULSES.mat`` for validation only). It runs

1. ``select`` with the linear / Coulomb / Coulomb + offset / Coulomb + v|v| / cubic candidates of the config (default
   settings): the ranking by evidence;
2. the loop from the linear model (:func:`bayesnsi.loop.close_the_loop`, default settings):
   the effects added, in order;
3. the physical measures: mass, viscous damping (from the identified FRF) and Coulomb force of the
   final model against the published IDIM-LS values, the force offset the final model needs (fitted
   on the estimation data) against the published one, the Coulomb + offset model identified by NSI
   on the record with the force's mean kept (its offset read at DC; the column shows the constant
   it needs in all, its NSI offset plus what remains on the estimation data), and the force-prediction error (the force
   predicted from the measured motion, IDIM view; both filtered at fs/20, means kept) on the
   validation file of the linear model (before), the final model (after) and the published inverse
   model (computed here from the published parameters). The validation file never enters a decision.
4. the friction reading of the loop's final model (:func:`bayesnsi.loop.friction_reading`: forward and
   backward viscous coefficients, Coulomb level and offset with 95 % intervals, least squares in the force
   view its evidence scores) and the error of the force it predicts on the validation file.

Writes ``OUT/emps.md`` (the table) and ``OUT/results.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from bayesnsi.exceptions import ConfigError
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
from bayesnsi.loop import close_the_loop, friction_reading
from bayesnsi.models import Term
from bayesnsi.nsi import force_prediction, identify
from bayesnsi.nsi.inverse import edge_samples, filtered_kinematics, inverse_force
from bayesnsi.selection import select

CONFIG = Path(__file__).parent / "emps" / "emps.toml"
PUBLISHED = {"mass": 95.1089, "damping": 203.5034, "coulomb": 20.3935, "offset": -3.1648}
TARGETS = {"mass": 0.02, "damping": 0.05, "coulomb": 0.05}


def _raw(config):
    """The same config with the means kept (the force offset is part of the force prediction)."""
    return dataclasses.replace(config, data=dataclasses.replace(config.data, remove_mean=False))


def _load(config_path):
    try:
        config = load_config(config_path)
    except ConfigError as err:
        raise SystemExit(
            f"emps: {err}\nthe config expects the EMPS files in ../shared/data/emps relative to the repository "
            "(see that folder's README)"
        ) from None
    missing = [p for p in [config.data.file, *(v.file for v in config.validation if v.file)] if not Path(p).exists()]
    if missing:
        raise SystemExit(
            f"emps: data file(s) not found: {', '.join(map(str, missing))}; the config expects the EMPS files "
            "in ../shared/data/emps relative to the repository (see that folder's README)"
        )
    return config


def published_force(signals, cutoff_hz=None):
    """The published inverse model's force prediction on ``signals`` (filtered as ours)."""
    x, v, a, f, cutoff = filtered_kinematics(signals, cutoff_hz)
    p = PUBLISHED
    predicted = inverse_force(
        p["mass"], p["damping"], 0.0, [Term("sign(v1)", 1)], [p["coulomb"]], x, v, a, p["offset"],
        fs=signals.fs, cutoff_hz=cutoff,
    )
    trim = edge_samples(signals.fs, cutoff)  # the ends force_prediction leaves out
    keep = slice(trim, len(f) - trim)
    return float(np.sqrt(np.mean((f - predicted)[keep] ** 2)))


def model_offset(result, signals) -> float:
    """The constant force the model needs on the estimation data (its mean force residual)."""
    zero = force_prediction(result, signals, offset=0.0)
    return float(np.mean(zero.measured - zero.predicted))


def force_row(name, result, est_raw, val_raw) -> dict:
    """Physical parameters, offset and force-prediction errors of one model."""
    (phys,) = result.physical_parameters
    coefs = {t.name: float(c) for t, c in zip(result.terms, result.coefficient_values)}
    # the constant force the model lacks on the estimation data (≈ 0 when it holds an offset term)
    offset = model_offset(result, est_raw)
    shown = offset + coefs.get("1@1", 0.0)
    return {
        "model": name,
        "terms": [t.name for t in result.terms],
        "mass": phys.mass,
        "damping": phys.damping,
        "stiffness": phys.stiffness,
        "coulomb": coefs.get("sign(v1)@1"),
        "coefficients": coefs,
        "offset": shown,
        "force_rmse_estimation": force_prediction(result, est_raw, offset=offset).rmse,
        "force_rmse_validation": force_prediction(result, val_raw, offset=offset).rmse,
    }


def run(config_path=CONFIG, quiet=False) -> dict:
    """Selection, loop and measures (module docstring)."""
    config = _load(config_path)
    signals = load_signals(config)
    segments = load_validation(config)
    est_raw = load_signals(_raw(config))
    val_raw = load_validation(_raw(config))[0][1]
    out: dict = {"settings": {"config": str(config_path), "nsi": config.nsi.to_dict()}, "versions": versions()}
    t0 = time.perf_counter()
    selection = select(signals, config.candidates, config.nsi, config.evidence, validation=segments)
    table = selection.table
    likelihood = config.evidence.likelihood
    ranking = []
    for outcome in selection.outcomes:
        row = table.loc[outcome.name] if table is not None and outcome.name in table.index else None
        ranking.append({
            "name": outcome.name,
            "log_evidence": None if row is None else float(row.get(f"log_evidence_{likelihood}", np.nan)),
            "posterior": None if row is None else float(row.get(f"p_{likelihood}", np.nan)),
            "error": outcome.error,
        })
    ranking.sort(key=lambda r: -(r["log_evidence"] if r["log_evidence"] is not None else -np.inf))
    out["select"] = {"ranking": ranking, "seconds": time.perf_counter() - t0, "warnings": list(selection.warnings),
                     "selected": selection.selected, "plausible": selection.plausible}
    if not quiet:
        print("select: " + ", ".join(f"{r['name']} ({r['log_evidence']})" for r in ranking), file=sys.stderr)
    t0 = time.perf_counter()
    linear = next(c for c in config.candidates if not c.terms)
    evidence = config.evidence.replace(residual=config.loop.residual)
    loop = close_the_loop(signals, linear, config.loop, nsi=config.nsi, evidence=evidence)
    out["loop"] = {
        "added": [{"expr": s.term.expr.text, "at": s.term.at_value, "log_bayes_factor": s.log_bayes_factor}
                  for s in loop.added],
        "rejected": [{"expr": s.term.expr.text, "reason": s.reason} for s in loop.steps if not s.accepted],
        "seconds": time.perf_counter() - t0,
    }
    before = identify(signals, linear, config.nsi)
    out["models"] = [
        force_row("linear (loop before)", before, est_raw, val_raw),
        force_row("loop after: " + (", ".join(t.name for t in loop.final.terms) or "linear"), loop.final, est_raw,
                  val_raw),
    ]
    # the offset as an effect: identified by NSI on the record with the force's mean kept (the
    # position's mean removed, as the loop's data), its coefficient read at DC
    x_mean = est_raw.displacement.mean(axis=0)
    kept = dataclasses.replace(signals, force=est_raw.force)
    val_kept = dataclasses.replace(val_raw, displacement=val_raw.displacement - x_mean)
    with_offset = identify(kept, [("sign(v1)", 1), ("1", 1)], config.nsi.replace(upsample=4))
    lam = float(with_offset.coefficient_values[1])
    out["models"].append(force_row(f"Coulomb + offset (force mean kept; NSI offset {lam:.3f} N)", with_offset, kept,
                                   val_kept))
    # the physical reading of the loop's final friction law, where its evidence scores it (force view)
    reading = friction_reading(loop.final, est_raw)
    out["friction"] = {**reading.as_dict(), "force_rmse_validation": reading.force_error(val_raw)}
    out["published"] = {
        **PUBLISHED,
        "force_rmse_estimation": published_force(est_raw),
        "force_rmse_validation": published_force(val_raw),
    }
    return out


def table(results: dict) -> str:
    """Markdown table: parameters and force-prediction errors, ours before/after and the published model."""
    pub = results["published"]
    lines = [
        "| model | M [kg] | Fv [N s/m] | Fc [N] | offset [N] | force error, estimation [N] | "
        "force error, validation (pulses) [N] |",
        "|" + " --- |" * 7,
    ]
    for row in results["models"]:
        fc = "-" if row["coulomb"] is None else f"{row['coulomb']:.3f} ({row['coulomb'] / pub['coulomb'] - 1:+.1%})"
        lines.append(
            f"| {row['model']} | {row['mass']:.2f} ({row['mass'] / pub['mass'] - 1:+.1%}) | "
            f"{row['damping']:.2f} ({row['damping'] / pub['damping'] - 1:+.1%}) | {fc} | {row['offset']:.3f} | "
            f"{row['force_rmse_estimation']:.3f} | {row['force_rmse_validation']:.3f} "
            f"({row['force_rmse_validation'] / pub['force_rmse_validation']:.2f}× published) |"
        )
    lines.append(
        f"| published IDIM-LS (Janot et al. 2019) | {pub['mass']:.4f} | {pub['damping']:.4f} | {pub['coulomb']:.4f} | "
        f"{pub['offset']:.4f} | {pub['force_rmse_estimation']:.3f} | {pub['force_rmse_validation']:.3f} |"
    )
    fr = results.get("friction")
    if fr:
        def cell(name, digits=2):
            low, high = fr["intervals"][name]
            return f"{fr[name]:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"

        lines += [
            "",
            "Friction reading of the loop's final model (" + ", ".join(fr["terms"]) + "; force view, least squares,"
            " 95 % intervals; `bayesnsi.loop.friction_reading`):",
            "",
            "| M [kg] | viscous forwards [N s/m] | viscous backwards [N s/m] | Coulomb [N] | offset [N] | "
            "force error, estimation [N] | force error, validation (pulses) [N] |",
            "|" + " --- |" * 7,
            f"| {cell('mass')} | {cell('viscous_forward')} | {cell('viscous_backward')} | {cell('coulomb', 3)} | "
            f"{cell('offset', 3)} | {fr['force_rmse']:.3f} | {fr['force_rmse_validation']:.3f} "
            f"({fr['force_rmse_validation'] / pub['force_rmse_validation']:.2f}× published) |",
        ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--force", action="store_true", help="overwrite existing results")
    parser.add_argument("--config", default=str(CONFIG))
    args = parser.parse_args(argv)
    results = run(args.config)
    out = prepare_output_dir(args.out, force=args.force)
    text = table(results)
    atomic_write_text(out / "emps.md", text)
    atomic_write_json(out / "results.json", to_jsonable(results))
    print(text)
    print("select ranking: " + ", ".join(
        f"{r['name']} (log Z {r['log_evidence']:.1f})" if r["log_evidence"] is not None else f"{r['name']} (failed)"
        for r in results["select"]["ranking"]))
    print(f"select: selected {results['select']['selected']}; the most probable that passes every physical check: "
          f"{results['select']['plausible']}")
    print("loop from linear added: " + (", ".join(
        f"{a['expr']} (log BF {a['log_bayes_factor']:.1f})" for a in results["loop"]["added"]) or "nothing"))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
