"""Free bodies that are not the EMPS axis, run through the command line at default settings.

Records are simulated here by an independent semi-implicit Euler integration at 20x the output rate
(500 Hz output, 60 s, a second realisation for ``[[validation]]``), written as CSV with a units row
and a TOML config a user writes from the README (file, columns, candidates; nothing else), and run
through the command line, ``bayesnsi select CONFIG`` and ``bayesnsi diagnose CONFIG --start
linear``, at default settings:

- ``twomass-*``: two carriages on rails (m1 2 kg, m2 1.5 kg) joined by a spring (4000 N/m) and a
  damper (4 N s/m), no spring or damper to ground; force on mass 1 (1-40 Hz random, 10 N rms, plus
  a 1.5 N 0.5 Hz travel), Coulomb friction 1.5 N on mass 2; both positions measured with 1 µm,
  0.1 mm or 2 % (of the std) noise; the force with 2 % noise. Elastic mode 10.872 Hz, ζ 0.0342.
  Candidates: linear, Coulomb at 2 (true), Coulomb at 1, v2|v2| at 2, (x1-x2)³.
- ``twomass-acc``: the same record measured by two accelerometers (2 % noise), ``integrate =
  { band_hz = [2, 100] }``.
- ``carriage-*``: one carriage (20 kg, viscous 30 N s/m, Coulomb 8 N) in a PD position loop
  (2e4 N/m, 800 N s/m) with a 10 N disturbance, position with 1 µm noise; ``nostop``: nothing else;
  ``stop``: an end stop 2e5 N/m beyond ±10 mm (19 % of the time in contact), not declared.
  Candidates: linear, Coulomb (true), v|v|, x³.

Printed per record: the selected candidate and its probability, the elastic mode (two-mass), the
true term's coefficient in the selected model, the loop's added effects, its validation error
before and after (force prediction for a one-DOF free body, else the measured quantity in closed
loop), the number of warnings select gave, and the loop's short-horizon simulation error (1 s
windows) before and after (free bodies).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/free_body_cli.py --out /tmp/free-bodies [--cases twomass-1um]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

FS, SUB, DURATION = 500.0, 20, 60.0
M1, M2, K, C, FC2 = 2.0, 1.5, 4000.0, 4.0, 1.5
MASS, FV, FC, KP, KV = 20.0, 30.0, 8.0, 2.0e4, 800.0
BIN = Path(sys.executable).with_name("bayesnsi")


def _band_limited(rng, n, fs, lo, hi, rms):
    spec = np.zeros(n // 2 + 1, complex)
    f = np.fft.rfftfreq(n, 1 / fs)
    sel = (f >= lo) & (f <= hi)
    spec[sel] = np.exp(1j * rng.uniform(0, 2 * np.pi, sel.sum()))
    x = np.fft.irfft(spec, n)
    return x * rms / x.std()


def two_mass(seed):
    """Columns t, f1, x1, x2, a1, a2 (noise-free)."""
    rng = np.random.default_rng(seed)
    n, h = int(DURATION * FS), 1 / (FS * SUB)
    t = np.arange(n * SUB) * h
    f = _band_limited(rng, n * SUB, FS * SUB, 1.0, 40.0, 10.0)
    f = f + 1.5 * np.sin(2 * np.pi * 0.5 * t + rng.uniform(0, 6.28))  # the travel (same draws as in one line)
    x1 = x2 = v1 = v2 = 0.0
    out = np.empty((n, 6))
    for k in range(n * SUB):
        spring = K * (x1 - x2) + C * (v1 - v2)
        a1, a2 = (f[k] - spring) / M1, (spring - FC2 * np.sign(v2)) / M2
        if k % SUB == 0:
            out[k // SUB] = (k * h, f[k], x1, x2, a1, a2)
        v1 += h * a1
        v2 += h * a2
        x1 += h * v1
        x2 += h * v2
    return out


def carriage(seed, stiffness, gap=0.010):
    """Columns t, tau, q (noise-free)."""
    rng = np.random.default_rng(seed)
    n, h = int(DURATION * FS), 1 / (FS * SUB)
    t = np.arange(n * SUB) * h
    ref = sum(0.006 * np.sin(2 * np.pi * fr * t + rng.uniform(0, 6.28)) for fr in rng.uniform(0.2, 1.5, 5))
    dist = _band_limited(rng, n * SUB, FS * SUB, 0.1, 60.0, 10.0)
    q = v = tau = 0.0
    out = np.empty((n, 3))
    for k in range(n * SUB):
        if k % SUB == 0:
            tau = KP * (ref[k] - q) - KV * v + dist[k]
            out[k // SUB] = (k * h, tau, q)
        stop = stiffness * (q - gap) if q > gap else (stiffness * (q + gap) if q < -gap else 0.0)
        v += h * (tau - FV * v - FC * np.sign(v) - stop) / MASS
        q += h * v
    return out


def _noisy(rng, x, pct=2.0, absolute=None):
    return x + rng.normal(0, absolute if absolute is not None else pct / 100 * x.std(), x.shape)


def _write(path, header, units, cols):
    with open(path, "w") as fh:
        fh.write(",".join(header) + "\n" + ",".join(units) + "\n")
        np.savetxt(fh, np.column_stack(cols), delimiter=",", fmt="%.9g")


TWO_MASS_CANDIDATES = """
[[candidates]]
name = "linear"
terms = []
[[candidates]]
name = "Coulomb at 2"
terms = [{ expr = "sign(v2)", at = 2 }]
[[candidates]]
name = "Coulomb at 1"
terms = [{ expr = "sign(v1)", at = 1 }]
[[candidates]]
name = "quadratic damping at 2"
terms = [{ expr = "v2*abs(v2)", at = 2 }]
[[candidates]]
name = "cubic spring 1-2"
terms = [{ expr = "(x1-x2)**3", at = [1, 2] }]
"""

CARRIAGE_CANDIDATES = """
[[candidates]]
name = "linear"
terms = []
[[candidates]]
name = "Coulomb"
terms = [{ expr = "sign(v1)", at = 1 }]
[[candidates]]
name = "quadratic damping"
terms = [{ expr = "v1*abs(v1)", at = 1 }]
[[candidates]]
name = "cubic"
terms = [{ expr = "x1**3", at = 1 }]
"""

CASES = {  # name: (kind, position noise [m] or None for 2 % of the std, accelerometers, stop stiffness)
    "twomass-1um": ("twomass", 1e-6, False, None),
    "twomass-0.1mm": ("twomass", 1e-4, False, None),
    "twomass-2pct": ("twomass", None, False, None),
    "twomass-acc": ("twomass", None, True, None),
    "carriage-nostop": ("carriage", 1e-6, False, 0.0),
    "carriage-stop": ("carriage", 1e-6, False, 2.0e5),
}


def write_case(name, folder: Path) -> Path:
    kind, xnoise, acc, stop = CASES[name]
    folder.mkdir(parents=True, exist_ok=True)
    for seed, tag in ((1, "est"), (2, "val")):
        rng = np.random.default_rng(100 + seed)
        if kind == "twomass":
            d = two_mass(seed)
            _write(folder / f"{tag}.csv", ["t", "f1", "x1", "x2", "a1", "a2"], ["s", "N", "m", "m", "m/s^2", "m/s^2"],
                   [d[:, 0], _noisy(rng, d[:, 1]), _noisy(rng, d[:, 2], absolute=xnoise),
                    _noisy(rng, d[:, 3], absolute=xnoise), _noisy(rng, d[:, 4]), _noisy(rng, d[:, 5])])
        else:
            d = carriage(seed, stop)
            _write(folder / f"{tag}.csv", ["t", "tau", "q"], ["s", "N", "m"],
                   [d[:, 0], _noisy(rng, d[:, 1]), _noisy(rng, d[:, 2], absolute=xnoise)])
    if kind == "twomass":
        responses = ("accelerations = { a1 = 1, a2 = 2 }\nintegrate = { band_hz = [2.0, 100.0] }" if acc
                     else "outputs = { x1 = 1, x2 = 2 }")
        data = f'inputs = {{ f1 = 1 }}\n{responses}\n'
        candidates = TWO_MASS_CANDIDATES
    else:
        data, candidates = 'inputs = { tau = 1 }\noutputs = { q = 1 }\nremove_mean = true\n', CARRIAGE_CANDIDATES
    config = folder / "config.toml"
    config.write_text(f'seed = 0\n[data]\nfile = "est.csv"\ntime_column = "t"\n{data}{candidates}\n'
                      '[[validation]]\nname = "second record"\nfile = "val.csv"\n')
    return config


def _run(*args) -> str:
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([str(BIN), *args, "--force", "--no-figures", "--quiet"], capture_output=True, text=True,
                          env=env, check=False)
    return done.stdout + done.stderr


def _coefficient(entries, expr):
    for c in entries:
        if c.get("expr", c.get("term", "")).split("@")[0] == expr:
            return c["value"]
    return float("nan")


def summarise(name, folder: Path) -> dict:
    kind = CASES[name][0]
    true_term, true_value = ("sign(v2)", FC2) if kind == "twomass" else ("sign(v1)", FC)
    sel = json.loads((folder / "select" / "results.json").read_text())
    chosen = next(c for c in sel["candidates"] if c["name"] == sel["selected"])
    row = next(r for r in sel["ranking"] if r["candidate"] == sel["selected"])
    modes = [(m["frequency_hz"], m["damping_ratio"]) for m in chosen.get("modes", [])]
    elastic = max(modes, default=(np.nan, np.nan))
    out = {"case": name, "selected": sel["selected"], "P": row.get("p_ar1", np.nan),
           "f_hz": elastic[0], "zeta": elastic[1], "rigid": len(chosen.get("rigid_body_poles", [])),
           "true_coef": _coefficient(chosen.get("coefficients", []), true_term) / true_value - 1,
           "warnings": len(sel["warnings"])}
    diag_file = folder / "diagnose" / "results.json"
    if diag_file.exists():
        diag = json.loads(diag_file.read_text())
        added = [f"{s['added']['expr']}@{s['added']['at']}" for s in diag["loop"] if s.get("accepted")]
        before = diag.get("validation_before") or [{}]
        after = diag.get("validation") or [{}]
        accepted = [s for s in diag["loop"] if s.get("accepted")]
        out["short"] = ((accepted[0].get("short_horizon_nrmse_before"), accepted[-1].get("short_horizon_nrmse_after"))
                        if accepted else (None, None))
        out.update(added=",".join(added) or "-", loop_coef=_coefficient(diag.get("final_coefficients", []), true_term)
                   / true_value - 1, before=before[0].get("nrmse", np.nan), after=after[0].get("nrmse", np.nan),
                   quantity=after[0].get("quantity", "-"))
    else:
        out.update(added="(diagnose failed)", loop_coef=np.nan, before=np.nan, after=np.nan, quantity="-",
                   short=(None, None))
    return out


def _text(value) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.3f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    args = parser.parse_args(argv)
    print(f"{'case':<16} {'selected':<23} {'P(ar1)':>7} {'f [Hz]':>7} {'zeta':>6} {'rigid':>5} {'true coef':>9}  "
          f"{'loop added':<22} {'loop coef':>9} {'valid. before->after':>22} {'warn':>4} "
          f"{'1 s windows before->after':>26}")
    for name in args.cases:
        folder = args.out / name
        config = write_case(name, folder)
        _run("select", str(config), "--out", str(folder / "select"))
        log = _run("diagnose", str(config), "--start", "linear", "--out", str(folder / "diagnose"))
        (folder / "diagnose.log").write_text(log)
        s = summarise(name, folder)
        print(f"{s['case']:<16} {s['selected']:<23} {s['P']:>7.3f} {s['f_hz']:>7.3f} {s['zeta']:>6.4f} {s['rigid']:>5} "
              f"{100 * s['true_coef']:>+8.1f}%  {s['added'][:22]:<22} {100 * s['loop_coef']:>+8.1f}% "
              f"{s['before']:>9.3f} -> {s['after']:.3f} {s['quantity'][:5]:<5} {s['warnings']:>4} "
              f"{_text(s['short'][0]):>12} -> {_text(s['short'][1])}", flush=True)
    print(f"truth: elastic mode {np.sqrt(K * (1 / M1 + 1 / M2)) / (2 * np.pi):.3f} Hz, zeta "
          f"{C * np.sqrt(K * (1 / M1 + 1 / M2)) / (2 * K):.4f}; Coulomb {FC2} N at mass 2 (two-mass), "
          f"{FC} N (carriage)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
