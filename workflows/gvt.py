"""Simulated ground vibration test: periodic data, accelerometers, an undeclared joint.

Usage::

    .venv/bin/python workflows/gvt.py --out out/gvt                      # data + configs + BLA table
    .venv/bin/python workflows/gvt.py --out out/gvt --command select     # + select (linear) per level
    .venv/bin/python workflows/gvt.py --out out/gvt --command diagnose --level 2

Simulates :func:`bayesnsi.simulate.gvt_records` (three levels, two realisations each), writes per
level and realisation ``OUT/data/level<i>_r<j>.csv`` (force and the three accelerations, whole
periods in steady state) and ``OUT/level<i>.toml``: ``[data] period``, accelerations integrated line
by line, ``[nsi] domain = "frequency"``, the linear model as the only candidate (the joint is not
declared), the other realisation and the other levels as ``[[validation]]``. Prints, per level,
the power at the unexcited odd and even lines over the noise for each sensor pair (relative
motion; the best linear approximation of :func:`bayesnsi.nsi.best_linear_approximation`). Then
runs ``bayesnsi select`` or ``bayesnsi diagnose --start linear`` on the chosen levels.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from bayesnsi import Signals
from bayesnsi.cli import main
from bayesnsi.io import dump_config
from bayesnsi.nsi import best_linear_approximation, periodic_integration
from bayesnsi.simulate import GVT_BAND_HZ, GVT_SENSORS, GVT_SHAKER, gvt_records

LEVELS = (0.1, 1.0, 8.0)
INTEGRATE_BAND = (1.0, 20.0)


def write(records, out: Path) -> list[Path]:
    """CSV per record and one config per level; the config paths."""
    (out / "data").mkdir(parents=True, exist_ok=True)
    names = {}
    for record in records:
        level = LEVELS.index(record.level)
        name = f"level{level}_r{record.realisation}.csv"
        columns = np.column_stack([record.force, record.acceleration])
        header = ",".join(["f2"] + [f"a{dof}" for dof in GVT_SENSORS])
        np.savetxt(out / "data" / name, columns, delimiter=",", header=header, comments="", fmt="%.10g")
        names[(level, record.realisation)] = name
    configs = []
    period, fs = records[0].period, records[0].fs
    for level in range(len(LEVELS)):
        validation = [{"name": f"level {level} realisation 1", "file": f"data/{names[(level, 1)]}"}]
        validation += [{"name": f"level {other}", "file": f"data/{names[(other, 0)]}"}
                       for other in range(len(LEVELS)) if other != level]
        config = {
            "seed": 0,
            "data": {
                "file": f"data/{names[(level, 0)]}", "fs": fs, "period": period,
                "inputs": {"f2": GVT_SHAKER}, "accelerations": {f"a{dof}": dof for dof in GVT_SENSORS},
                "integrate": {"band_hz": list(INTEGRATE_BAND)},
            },
            # order 20: the 9 modes in the band and one pair for those just above it; D free: the residual
            # flexibility of the modes above the band (on the 2-DOF chain, with no such mode, D = 0 is better)
            "nsi": {"domain": "frequency", "band_hz": list(GVT_BAND_HZ), "order": 20, "block_rows": 20,
                    "zero_feedthrough": False},
            "candidates": [{"name": "linear", "terms": []}],
            "validation": validation,
        }
        path = out / f"level{level}.toml"
        path.write_text(dump_config(config))
        configs.append(path)
    return configs


def distortion_table(records) -> None:
    """Power at the unexcited odd / even lines over the noise, per level and sensor pair."""
    pairs = [(i, j) for i in range(3) for j in range(i + 1, 3)]
    print("level [N] | pair | odd / noise | even / noise")
    for level in LEVELS:
        signals = []
        for record in (r for r in records if r.level == level):
            _, x = periodic_integration(record.acceleration, record.fs, record.period, INTEGRATE_BAND)
            rel = np.column_stack([x[:, i] - x[:, j] for i, j in pairs])
            signals.append(Signals(force=record.force, displacement=rel, fs=record.fs, input_dofs=(GVT_SHAKER,),
                                   output_dofs=tuple(range(1, len(pairs) + 1)), period=record.period))
        ratio = best_linear_approximation(signals).unexcited_ratio()
        for k, (i, j) in enumerate(pairs):
            pair = f"{GVT_SENSORS[i]}-{GVT_SENSORS[j]}"
            print(f"{level:9g} | {pair}  | {ratio['odd'][k]:11.1f} | {ratio['even'][k]:12.1f}")


def run(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--command", choices=("none", "select", "diagnose"), default="none")
    parser.add_argument("--level", type=int, nargs="+", default=list(range(len(LEVELS))),
                        help="levels (0 = lowest) the command runs on")
    args = parser.parse_args(argv)
    out = Path(args.out)
    records = gvt_records(levels=LEVELS, n_realisations=2, seed=args.seed)
    configs = write(records, out)
    distortion_table(records)
    code = 0
    if args.command == "select":
        for level in args.level:
            code |= main(["select", str(configs[level]), "--out", str(out / f"select{level}"), "--force"])
    elif args.command == "diagnose":
        for level in args.level:
            code |= main(["diagnose", str(configs[level]), "--start", "linear",
                          "--out", str(out / f"diagnose{level}"), "--force"])
    return code


if __name__ == "__main__":
    sys.exit(run())
