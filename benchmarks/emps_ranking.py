"""Why ``select`` ranks Coulomb + v|v| above Coulomb on the EMPS axis (issue 14): sensitivity table.

An independent computation (numpy least squares, not the package's evidence): the force view of
:mod:`bayesnsi.nsi.inverse` (4th-order zero-phase low-pass at the cutoff, central differences,
nonlinear columns filtered once more), the linear part ``[a, v, x, 1]`` profiled out, the
coefficients of sign(v) and v|v| integrated over the default zero-mean Normal priors (scale
rms(force) / rms(column)), white Gaussian noise at its maximum-likelihood level, one sample per
``step``. Per variant: the log evidence of Coulomb + v|v| minus that of Coulomb [nat]. Then the
force-prediction errors of least-squares fits on the estimation file, on both files.

Run: ``.venv/bin/python benchmarks/emps_ranking.py`` (needs ``../shared/data/emps``; ≈ 5 s)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.io
from scipy import signal

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "emps"


def load(name):
    d = scipy.io.loadmat(DATA / name)
    return d["qm"][:, 0], float(d["gtau"][0, 0]) * d["vir"][:, 0], d["qg"][:, 0]


def view(q, f, cutoff=50.0, fs=1000.0):
    sos = signal.butter(4, cutoff, fs=fs, output="sos")
    x, ff = signal.sosfiltfilt(sos, q), signal.sosfiltfilt(sos, f)
    v = np.gradient(x, 1 / fs)
    a = np.gradient(v, 1 / fs)
    return {"a": a, "v": v, "x": x, "1": np.ones_like(x), "s": signal.sosfiltfilt(sos, np.sign(v)),
            "vv": signal.sosfiltfilt(sos, v * np.abs(v)), "f": ff}


def log_evidence(y, profiled, terms, scales):
    """Gaussian evidence of y = profiled θ + terms λ + e, λ ~ N(0, diag(scales²)), σ at its ML value."""
    q, _ = np.linalg.qr(profiled)
    yp, b = y - q @ (q.T @ y), terms - q @ (q.T @ terms)
    n = len(y) - profiled.shape[1]
    coef = np.linalg.lstsq(b, yp, rcond=None)[0]
    s2 = float(np.sum((yp - b @ coef) ** 2)) / n
    prec = np.diag(1 / scales**2) + b.T @ b / s2
    rhs = b.T @ yp / s2
    quad = yp @ yp / s2 - rhs @ np.linalg.solve(prec, rhs)
    logdet = n * np.log(s2) + np.linalg.slogdet(prec)[1] + np.sum(np.log(scales**2))
    return -0.5 * (n * np.log(2 * np.pi) + logdet + quad)


def gap(c, f_rms, step=20, offset=0, linear=("a", "v", "x", "1"), prior=1.0, edge=100):
    keep = slice(edge + offset, len(c["f"]) - edge, step)
    n_lin = np.column_stack([c[k] for k in linear])[keep]
    scale = {k: prior * f_rms / np.sqrt(np.mean(c[k] ** 2)) for k in ("s", "vv")}
    one = log_evidence(c["f"][keep], n_lin, c["s"][keep, None], np.array([scale["s"]]))
    both = np.column_stack([c["s"], c["vv"]])[keep]
    two = log_evidence(c["f"][keep], n_lin, both, np.array([scale["s"], scale["vv"]]))
    return two - one


def main() -> int:
    if not (DATA / "DATA_EMPS.mat").exists():
        print(f"EMPS data not found in {DATA}")
        return 1
    q, f, qg = load("DATA_EMPS.mat")
    qv, fv, _ = load("DATA_EMPS_PULSES.mat")
    f_rms = float(np.sqrt(np.mean(f**2)))
    base = view(q, f)
    half = len(q) // 2
    rows = [
        ("default (50 Hz, one sample in 20)", gap(base, f_rms)),
        ("stiffness column not profiled", gap(base, f_rms, linear=("a", "v", "1"))),
        ("prior scales x0.1", gap(base, f_rms, prior=0.1)),
        ("prior scales x10", gap(base, f_rms, prior=10.0)),
        ("one sample in 100", gap(base, f_rms, step=100)),
        ("one sample in 200", gap(base, f_rms, step=200)),
        ("cutoff 10 Hz, one in 100", gap(view(q, f, 10.0), f_rms, step=100, edge=500)),
        ("cutoff 25 Hz, one in 40", gap(view(q, f, 25.0), f_rms, step=40, edge=200)),
        ("cutoff 100 Hz, one in 10", gap(view(q, f, 100.0), f_rms, step=10)),
        ("motion from the reference qg", gap({**view(qg, f), "f": base["f"]}, f_rms)),
        ("validation file alone", gap(view(qv, fv), f_rms)),
        ("first half", gap(view(q[:half], f[:half]), f_rms)),
        ("second half", gap(view(q[half:], f[half:]), f_rms)),
    ]
    rows += [(f"decimation phase {k}", gap(base, f_rms, offset=k)) for k in (4, 8, 12, 16)]
    print(f"{'variant':<36} {'log Z(C + v|v|) - log Z(C) [nat]':>34}")
    for name, value in rows:
        print(f"{name:<36} {value:>34.1f}")
    val = view(qv, fv)
    keep = slice(100, -100)
    print(f"\n{'least squares on the estimation file':<44} {'est. [N]':>9} {'valid. [N]':>10}  parameters")
    fits = (("M, Fv, Fc, offset", ("a", "v", "s", "1")), ("M, Fv, Fc, offset, v|v|", ("a", "v", "s", "1", "vv")))
    for name, cols in fits:
        design = np.column_stack([base[k] for k in cols])[keep]
        theta = np.linalg.lstsq(design, base["f"][keep], rcond=None)[0]
        est = np.sqrt(np.mean((base["f"][keep] - design @ theta) ** 2))
        vres = val["f"][keep] - np.column_stack([val[k] for k in cols])[keep] @ theta
        print(f"{name:<44} {est:>9.3f} {np.sqrt(np.mean(vres**2)):>10.3f}  {np.round(theta, 2).tolist()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
