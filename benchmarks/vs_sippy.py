"""identify() against SIPPY's N4SID fed the same extended input.

Case (docs/method.md §10, "Errors in variables"): two-DOF chain (masses 1, 1.5 kg; springs 800,
1000 N/m; dampers 1, 1 N s/m), a cubic spring k3·x1³ at DOF 1 whose force is about 13 % of the
linear spring's (rms), a band-limited white force at DOF 2 (10 N rms, RK4 on an 8x finer grid),
1e5 samples at 100 Hz, 2 % output noise; i = 20 block rows, order n = 4.

Both methods get the same extended input ``[f, -x1³]`` (from the noisy x1) and the displacements;
k3 is read the same way from each identified model: the band mean (1-10 Hz) of Re λ(ω) from its
extended FRF (:func:`bayesnsi.nsi.coefficient_spectrum`). Times are the best of ``--repeat`` runs,
one thread.

SIPPY is never a dependency of bayesnsi: install it in a scratch environment and point
``--sippy-python`` at it (or run this script with that environment's python, with bayesnsi on
``PYTHONPATH``); without it the script says so and times identify() alone::

    python3 -m venv /tmp/sippyenv && /tmp/sippyenv/bin/pip install sippy-unipi
    .venv/bin/python benchmarks/vs_sippy.py --sippy-python /tmp/sippyenv/bin/python
    .venv/bin/python benchmarks/vs_sippy.py --profile      # where identify() spends its time
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

FS, N_SAMPLES, BLOCK_ROWS, ORDER, NOISE_PERCENT, BAND_HZ = 100.0, 100_000, 20, 4, 2.0, (1.0, 10.0)
MASSES, SPRINGS, DAMPERS, FORCE_RMS, CUBIC_SHARE = [1.0, 1.5], [800.0, 1000.0], [1.0, 1.0], 10.0, 0.13


def make_case(seed: int = 0):
    """Noisy Signals, the true k3 and the candidate ``x1**3 @ 1``."""
    from bayesnsi.models import CandidateModel, Term
    from bayesnsi.signals import Signals
    from bayesnsi.simulate import add_output_noise, band_limited_gaussian, chain_system, simulate_response

    M, C, K = chain_system(MASSES, SPRINGS, DAMPERS)
    rng = np.random.default_rng(seed)
    excitation = band_limited_gaussian(N_SAMPLES, FS, FORCE_RMS, rng, oversample=8)
    linear = simulate_response(M, C, K, [2], excitation.fine[:20_000 * 8], FS * 8, 8)
    sigma = linear.displacement[:, 0].std()
    k3 = CUBIC_SHARE * SPRINGS[0] / (np.sqrt(15.0) * sigma**2)  # rms(k3 x³) = √15 k3 σ³ for Gaussian x
    term = Term("x1**3", 1)
    response = simulate_response(M, C, K, [2], excitation.fine, FS * 8, 8, [term], [k3])
    disp = add_output_noise(response.displacement, NOISE_PERCENT, rng)
    vel = add_output_noise(response.velocity, NOISE_PERCENT, rng)
    signals = Signals(
        force=excitation.samples, displacement=disp, velocity=vel, fs=FS, input_dofs=(2,), output_dofs=(1, 2)
    )
    return signals, float(k3), CandidateModel("cubic", (term,))


def k3_of(A, B, C, D, dt):
    """Band-mean Re λ(ω) of the cubic term from a discrete model's extended FRF."""
    from bayesnsi.models import Term
    from bayesnsi.nsi import StateSpaceModel, coefficient_spectrum

    model = StateSpaceModel(np.asarray(A), np.asarray(B), np.asarray(C), np.asarray(D), dt)
    freqs = np.linspace(*BAND_HZ, 200)
    spectrum = coefficient_spectrum(model.frf(freqs), (2,), (1, 2), (Term("x1**3", 1),))
    return float(np.mean(spectrum[:, 0].real))


SIPPY_RUNNER = r'''
import json, sys, time
import numpy as np
from sippy_unipi import system_identification
data = np.load(sys.argv[1])
u, y, repeat = data["u"], data["y"], int(sys.argv[2])
best = np.inf
for _ in range(repeat):
    t0 = time.perf_counter()
    i, order = int(data["i"]), int(data["order"])
    sys_id = system_identification(y.T, u.T, "N4SID", SS_fixed_order=order, SS_f=i, SS_p=i)
    best = min(best, time.perf_counter() - t0)
np.savez(sys.argv[3], A=sys_id.A, B=sys_id.B, C=sys_id.C, D=sys_id.D)
print(json.dumps({"time_s": best}))
'''


def run_sippy(python: str, u, y, repeat: int):
    """SIPPY's N4SID in ``python`` (a separate environment): (time_s, (A, B, C, D)) or None."""
    with tempfile.TemporaryDirectory() as tmp:
        data, out, runner = Path(tmp, "data.npz"), Path(tmp, "model.npz"), Path(tmp, "runner.py")
        np.savez(data, u=u, y=y, order=ORDER, i=BLOCK_ROWS)
        runner.write_text(SIPPY_RUNNER)
        done = subprocess.run([python, str(runner), str(data), str(repeat), str(out)], capture_output=True, text=True)
        if done.returncode != 0:
            print(f"SIPPY run failed: {done.stderr.strip().splitlines()[-1:]}")
            return None
        model = np.load(out)
        return json.loads(done.stdout.strip().splitlines()[-1])["time_s"], tuple(model[k] for k in "ABCD")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sippy-python", help="python of an environment with sippy-unipi installed")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true", help="cProfile of one identify() (top 15 by own time)")
    args = parser.parse_args(argv)
    from bayesnsi.nsi import identify
    from bayesnsi.options import NSIOptions

    signals, k3, candidate = make_case()
    options = NSIOptions(block_rows=BLOCK_ROWS, order=ORDER, band_hz=BAND_HZ)
    identify(signals, candidate, options)  # warm-up (imports, caches)
    best = np.inf
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        result = identify(signals, candidate, options)
        best = min(best, time.perf_counter() - t0)
    rows = [("bayesnsi identify", best, result.coefficient_values[0] / k3 - 1)]
    if args.profile:
        import cProfile
        import pstats

        profile = cProfile.Profile()
        profile.runcall(identify, signals, candidate, options)
        pstats.Stats(profile).sort_stats("tottime").print_stats(15)
    python = args.sippy_python or sys.executable
    u, y = result.extended_input(signals), np.asarray(signals.displacement)
    sippy = run_sippy(python, u, y, args.repeat) if (args.sippy_python or _has_sippy()) else None
    if sippy is None:
        print("SIPPY not available (pip install sippy-unipi in a scratch venv, then --sippy-python): identify() only")
    else:
        t_sippy, (A, B, C, D) = sippy
        rows.append(("SIPPY N4SID, same extended input", t_sippy, k3_of(A, B, C, D, 1 / FS) / k3 - 1))
    print(f"\ntwo-DOF chain, x1^3 at DOF 1 (k3 = {k3:.4g} N/m^3), {N_SAMPLES} samples, {NOISE_PERCENT} % noise, "
          f"i = {BLOCK_ROWS}, n = {ORDER}, best of {args.repeat}")
    print(f"{'method':36s} {'time [s]':>9s} {'k3 error':>9s}")
    for name, seconds, error in rows:
        print(f"{name:36s} {seconds:9.4f} {100 * error:+8.2f} %")
    if len(rows) == 2:
        print(f"speed-up: {rows[1][1] / rows[0][1]:.0f}x (target >= 100x)")
    return 0


def _has_sippy() -> bool:
    import importlib.util

    return importlib.util.find_spec("sippy_unipi") is not None


if __name__ == "__main__":
    sys.exit(main())
