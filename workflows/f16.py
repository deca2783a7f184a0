"""The F-16 ground vibration test (measured): BLA, linear reference, modes against level, the loop.

Usage::

    .venv/bin/python workflows/f16.py --out out/f16                       # every step
    .venv/bin/python workflows/f16.py --out out/f16 --steps bla linear    # some of them

Data: ``../shared/data/f16`` (its README says what is known; J.P. Noël and M. Schoukens, "F-16 aircraft
benchmark based on ground vibration test data", 2017). Configs: ``workflows/f16/level{1,3,5}.toml``
(frequency route, fitted band 2-15 Hz, accelerations integrated line by line over 2-60 Hz for the
estimation record and over the fitted band for the validation records, order "auto"). Steps:

- ``bla``: per full-multisine level the force, the noise of the best linear approximation (from the
  period scatter) and its prediction error on the other levels (the estimation level's BLA applied to
  the other record's force, on the same lines); per random-odd record the output power at its
  detection lines (unexcited odd and even lines) over the noise; the data-only localisation
  (:func:`bayesnsi.loop.localise.location_distortion`) of every record, per sensor and pair.
- ``linear``: the linear model of each level's config, its validation errors beside the BLA's
  prediction errors on the same records (the ratio the linear part is judged by), and the model's error
  with its FRF taken on the BLA's lines and interpolated as the BLA is (like for like on the random-odd
  records' finer grid).
- ``modes``: frequency and damping of the modes in the band at every level (full multisines and
  random-odd records): the classic picture of a nonlinear structure.
- ``diagnose``: ``bayesnsi diagnose --start linear`` at levels 3 and 5 with the default acceptance rule
  (the quality index judged against the model's misfit, :mod:`bayesnsi.loop.quality`), and again with the
  quality index not applied (``--max-imag-ratio 1e9``: what the other guards and the held-out records
  say); the validation errors before and after, each effect of the first search with its index, misfit
  ratio κ, memory resolution M and held-out errors, and the benchmark's figure of merit (rms error of each
  simulated output, m/s²) on the fitted band and over the whole measured signal.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from bayesnsi.checks.validation import validate
from bayesnsi.cli import main
from bayesnsi.io import load_config, load_signals, load_validation
from bayesnsi.loop.localise import location_distortion
from bayesnsi.loop.quality import MisfitReading, misfit_reading
from bayesnsi.models import CandidateModel, Term
from bayesnsi.nsi import identify, period_dft

ROOT = Path(__file__).resolve().parent
CONFIGS = {level: ROOT / "f16" / f"level{level}.toml" for level in (1, 3, 5)}
DATA = (ROOT.parent.parent / "shared" / "data" / "f16").resolve()
FS, PERIOD, ODD_PERIOD, BAND = 400.0, 8192, 16384, (2.0, 15.0)
LOCATIONS = [(1,), (2,), (3,), (1, 2), (1, 3), (2, 3)]
STEPS = ("bla", "linear", "modes", "diagnose")


def raw(name: str) -> np.ndarray:
    """Force and the three accelerations of a benchmark file, shape (n, 4)."""
    return np.genfromtxt(DATA / name, delimiter=",", skip_header=1, usecols=(0, 2, 3, 4))


def full(level: int) -> np.ndarray:
    return raw(f"F16Data_FullMSine_Level{level}.csv")


def odd(level: int) -> np.ndarray:
    return raw(f"F16Data_SpecialOddMSine_Level{level}_Validation.csv")


def spectra(record: np.ndarray, period: int):
    """Period-averaged force and acceleration spectra (first period dropped) and the acceleration noise variance."""
    force = period_dft(record[:, 0], period, drop=1)[..., 0]
    accel = period_dft(record[:, 1:], period, drop=1)
    n = accel.shape[0]
    return force.mean(axis=0), accel.mean(axis=0), np.var(accel, axis=0, ddof=1) / n


def band_lines(period: int) -> np.ndarray:
    f = np.fft.rfftfreq(period, 1.0 / FS)
    return (f >= BAND[0]) & (f <= BAND[1])


def bla_error(estimation: int, other: np.ndarray, period: int) -> np.ndarray:
    """NRMSE per sensor of the level's BLA applied to ``other``'s force on the fitted band (accelerations)."""
    f_est, a_est, _ = spectra(full(estimation), PERIOD)
    keep = band_lines(PERIOD)
    return frf_error(a_est[keep] / f_est[keep, None], other, period)


def model_frf(result, freqs_hz: np.ndarray) -> np.ndarray:
    """Acceleration over force of a linear model's FRF at ``freqs_hz``, shape (n, 3)."""
    return -((2 * np.pi * freqs_hz[:, None]) ** 2) * result.underlying_frf(freqs_hz)[:, :, 0]


def frf_error(frf: np.ndarray, other: np.ndarray, period: int) -> np.ndarray:
    """NRMSE per sensor of an FRF on the estimation record's lines (``PERIOD``, fitted band) applied to ``other``.

    On another line grid (the random-odd records' period is twice as long: their lines fall between the
    estimation record's) the FRF is interpolated between its lines, real and imaginary parts linearly.
    """
    f_est_hz = np.fft.rfftfreq(PERIOD, 1.0 / FS)[band_lines(PERIOD)]
    f_val, a_val, _ = spectra(other, period)
    lines = band_lines(period)
    freqs = np.fft.rfftfreq(period, 1.0 / FS)[lines]
    excited = np.abs(f_val[lines]) ** 2 > 1e-4 * np.max(np.abs(f_val[lines]) ** 2)
    g = np.column_stack([np.interp(freqs, f_est_hz, col.real) + 1j * np.interp(freqs, f_est_hz, col.imag)
                         for col in frf.T])
    predicted = g * f_val[lines, None]
    measured = a_val[lines]
    error = np.where(excited[:, None], measured - predicted, measured)  # unexcited lines: a linear model gives 0
    return np.sqrt(np.sum(np.abs(error) ** 2, axis=0) / np.sum(np.abs(measured) ** 2, axis=0))


def step_bla() -> None:
    print("\n## Best linear approximation, noise and distortion")
    print("| record | force rms [N] | BLA noise std / abs(BLA), median over 2-15 Hz (sensors 1, 2, 3) |")
    print("| --- | --- | --- |")
    for level in (1, 3, 5):
        force, accel, var = spectra(full(level), PERIOD)
        lines = band_lines(PERIOD)
        rms = np.sqrt(2 * np.sum(np.abs(force[1:]) ** 2))
        rel = np.median(np.sqrt(var[lines]) / np.abs(accel[lines]), axis=0)
        print(f"| full multisine level {level} | {rms:.1f} | {', '.join(f'{v:.2e}' for v in rel)} |")
    print("\nPrediction error (NRMSE per sensor, fitted band) of the BLA of one level on another's force:")
    print("| BLA of | level 1 | level 3 | level 5 |")
    print("| --- | --- | --- | --- |")
    for est in (1, 3, 5):
        cells = ["-" if est == val else ", ".join(f"{v:.3f}" for v in bla_error(est, full(val), PERIOD))
                 for val in (1, 3, 5)]
        print(f"| level {est} | " + " | ".join(cells) + " |")
    print("\nRandom-odd records: median output power at the detection lines (2-15 Hz) over its noise level,")
    print("per sensor and for the relative motion 2-3 (1: no distortion):")
    print("| record | force rms [N] | odd lines (1, 2, 3, 2-3) | even lines (1, 2, 3, 2-3) |")
    print("| --- | --- | --- | --- |")
    for level in (1, 2, 3):
        record = odd(level)
        force, accel, var = spectra(record, ODD_PERIOD)
        rel = accel[:, 1] - accel[:, 2]
        rel_var = np.var(period_dft(record[:, 2] - record[:, 3], ODD_PERIOD, drop=1)[..., 0], axis=0, ddof=1) / 2
        power = np.column_stack([np.abs(accel) ** 2, np.abs(rel) ** 2])
        noise = np.column_stack([var, rel_var])
        k = np.arange(len(force))
        inside = band_lines(ODD_PERIOD)
        excited = np.abs(force) ** 2 > 1e-4 * np.max(np.abs(force[inside]) ** 2)
        ratio = {name: np.median(power[inside & ~excited & (k % 2 == parity)]
                                 / noise[inside & ~excited & (k % 2 == parity)], axis=0)
                 for name, parity in (("odd", 1), ("even", 0))}
        rms = np.sqrt(2 * np.sum(np.abs(force[1:]) ** 2))
        print(f"| random-odd level {level} | {rms:.1f} | {', '.join(f'{v:.1f}' for v in ratio['odd'])} | "
              f"{', '.join(f'{v:.1f}' for v in ratio['even'])} |")
    print("\nData-only localisation: distortion level of each location (its motion's power at the detection lines")
    print("over that at the excited lines; NaN: nothing above the noise) and the lead of the first over the second:")
    print("| record | " + " | ".join("-".join(map(str, loc)) for loc in LOCATIONS) + " | lead |")
    print("| --- " * (len(LOCATIONS) + 2) + "|")
    records = [(f"full multisine level {lv}", CONFIGS[lv], None) for lv in (1, 3, 5)]
    records += [(f"random-odd level {lv}", CONFIGS[5], f"random-odd level {lv}") for lv in (1, 2, 3)]
    for name, path, segment in records:
        config = load_config(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if segment is None:
                signals = load_signals(config)
            else:  # the random-odd record integrated as the estimation records are (2-60 Hz)
                wide = load_config(path)
                signals = _wide_segment(wide, segment)
        levels = location_distortion(signals, LOCATIONS)
        values = [levels[loc][0] for loc in LOCATIONS]
        ranked = sorted((v for v in values if np.isfinite(v)), reverse=True)
        lead = f"{LOCATIONS[int(np.nanargmax(values))]}: {ranked[0] / ranked[1]:.1f}x" if len(ranked) > 1 else "-"
        print(f"| {name} | " + " | ".join(f"{v:.2e}" for v in values) + f" | {lead} |")


def _wide_segment(config, name: str):
    """A validation record of ``config`` integrated over the estimation record's band (2-60 Hz)."""
    import dataclasses

    segments = [dataclasses.replace(s, integrate=None) for s in config.validation if s.name == name]
    return load_validation(dataclasses.replace(config, validation=tuple(segments)))[0][1]


def _linear(level: int):
    config = load_config(CONFIGS[level])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        signals, segments = load_signals(config), load_validation(config)
        result = identify(signals, CandidateModel("linear", ()), config.nsi)
    return config, signals, segments, result


def step_linear() -> None:
    print("\n## Linear models: validation error against the BLA's prediction error (NRMSE, fitted band)")
    print("The BLA is known on the estimation record's lines only; on the random-odd records' finer grid it is")
    print("interpolated, which blunts its resonance peaks. 'on the BLA's lines': the linear model's FRF taken on")
    print("the same lines and interpolated the same way (like for like; equal to the model's own on the full")
    print("multisines).")
    print("| estimation | order (stable modes) | record | linear model | BLA of the estimation level | ratio "
          "| linear model on the BLA's lines | ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    lines_hz = np.fft.rfftfreq(PERIOD, 1.0 / FS)[band_lines(PERIOD)]
    for level in (1, 3, 5):
        start = time.perf_counter()
        _, _, segments, result = _linear(level)
        elapsed = time.perf_counter() - start
        stable = list(result.fit.stable_modes_hz)
        on_lines = model_frf(result, lines_hz)
        for found in validate(result, segments):
            name = found.name
            other = full(int(name[-1])) if name.startswith("full") else odd(int(name[-1]))
            period = PERIOD if name.startswith("full") else ODD_PERIOD
            bla = bla_error(level, other, period)
            bla_all = float(np.sqrt(np.mean(bla**2)))
            same = float(np.sqrt(np.mean(frf_error(on_lines, other, period) ** 2)))
            print(f"| level {level} ({elapsed:.0f} s) | {result.order} ({len(stable)}) | {name} | {found.nrmse:.3f} "
                  f"| {bla_all:.3f} | {found.nrmse / bla_all:.2f} | {same:.3f} | {same / bla_all:.2f} |")


def step_modes() -> None:
    print("\n## Modes in the band against the excitation level (linear model of each record, order auto)")
    rows = []
    for level in (1, 3, 5):
        result = _linear(level)[3]
        rows.append((f"full multisine level {level}", result))
    config = load_config(CONFIGS[1])
    import dataclasses

    for level in (1, 2, 3):  # each random-odd record as an estimation record of its own
        data = dataclasses.replace(config.data, file=DATA / f"F16Data_SpecialOddMSine_Level{level}_Validation.csv",
                                   period=ODD_PERIOD, estimation=(ODD_PERIOD, 3 * ODD_PERIOD))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            signals = load_signals(dataclasses.replace(config, data=data, validation=()))
            rows.append((f"random-odd level {level}", identify(signals, CandidateModel("linear", ()), config.nsi)))
    reference = [m for m in rows[0][1].modes if BAND[0] <= m.frequency_hz <= BAND[1]]
    print("| record | " + " | ".join(f"mode near {m.frequency_hz:.2f} Hz: f [Hz], ζ [%]" for m in reference) + " |")
    print("| --- " * (len(reference) + 1) + "|")
    for name, result in rows:
        modes = [m for m in result.modes if BAND[0] <= m.frequency_hz <= BAND[1]]
        cells = []
        for ref in reference:
            near = min(modes, key=lambda m: abs(m.frequency_hz - ref.frequency_hz), default=None)
            ok = near is not None and abs(near.frequency_hz / ref.frequency_hz - 1) < 0.05
            cells.append(f"{near.frequency_hz:.3f}, {100 * near.damping_ratio:.2f}" if ok else "-")
        print(f"| {name} | " + " | ".join(cells) + " |")


def figure_of_merit(result, segment: str, level: int | None, record: np.ndarray, period: int) -> tuple:
    """RMS error [m/s²] of each simulated output on a record: on the fitted band, and against the whole signal.

    The model's periodic steady state (harmonic balance on the fitted lines, driven by the measured force
    only) differentiated line by line into accelerations, against the period-averaged measured acceleration
    on the same lines, and against every sample of the steady periods (the benchmark's figure of merit).
    """
    config = load_config(CONFIGS[level])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        signals = dict(load_validation(config))[segment]
    rec = result.reconstruct(signals, closed_loop=True)
    n = signals.n_samples
    omega = 2 * np.pi * np.fft.rfftfreq(n, 1.0 / FS)
    predicted = np.fft.irfft(-(omega**2)[:, None] * np.fft.rfft(rec.predicted, axis=0), n, axis=0)
    measured = record[period : period + n, 1:]
    measured = measured - measured.mean(axis=0)
    whole = np.sqrt(np.mean((measured - predicted) ** 2, axis=0))
    keep = (np.fft.rfftfreq(n, 1.0 / FS) >= BAND[0]) & (np.fft.rfftfreq(n, 1.0 / FS) <= BAND[1])
    in_band = np.fft.irfft(np.where(keep[:, None], np.fft.rfft(measured, axis=0), 0), n, axis=0)
    band = np.sqrt(np.mean((in_band - predicted) ** 2, axis=0))
    return band, whole, np.sqrt(np.mean(measured**2, axis=0))


def step_diagnose(out: Path) -> None:
    print("\n## Closing the loop from the linear model")
    for level in (3, 5):
        rules = (("default acceptance rule", []), ("quality index not applied", ["--max-imag-ratio", "1e9"]))
        for label, extra in rules:
            folder = out / f"diagnose{level}" / ("default" if not extra else "no-quality-index")
            start = time.perf_counter()
            code = main(["diagnose", str(CONFIGS[level]), "--start", "linear", "--out", str(folder), "--force",
                         "--quiet", *extra])
            elapsed = time.perf_counter() - start
            results = json.loads((folder / "results.json").read_text())
            added = [step["added"] for step in results.get("loop", [])]
            first = next((s for s in results.get("loop_scores", [[]])[0]), None)
            print(f"\nlevel {level}, {label} (exit {code}, {elapsed:.0f} s): added "
                  + (", ".join(f"{a['expr']}@{'-'.join(map(str, np.atleast_1d(a['at'])))}" for a in added) or "nothing")
                  + (f"; first effect checked {first['term']} ({first['status']}: {first['reason']})" if first else ""))
            before = {s["name"]: s for s in results.get("validation_before", [])}
            print("| record | NRMSE before | NRMSE after | rms error per output before [m/s²] | after [m/s²] |")
            print("| --- | --- | --- | --- | --- |")
            for seg in results.get("validation", []):
                b = before.get(seg["name"], {})
                print(f"| {seg['name']} | {_number(b.get('nrmse'))} | {_number(seg.get('nrmse'), seg.get('error'))} | "
                      + ", ".join(f"{v:.4f}" for v in b.get("rmse_per_channel", [])) + " | "
                      + ", ".join(f"{v:.4f}" for v in seg.get("rmse_per_channel", [])) + " |")
            if not extra:
                _acceptance_table(level, results)
            if added:
                _figure_of_merit_table(level, added)


def _number(value, error=None) -> str:
    """A table cell: the value to 3 decimals, or why there is none."""
    if value is None:
        return "failed: " + (error or "")[:50] if error else "-"
    return f"{value:.3f}"


def _acceptance_table(level: int, results: dict) -> None:
    """The first search's re-identified effects: the guards' values and what each does on the held-out records."""
    config = load_config(CONFIGS[level])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        signals, segments = load_signals(config), load_validation(config)
        linear = identify(signals, CandidateModel("linear", ()), config.nsi)
        nsi = config.nsi.replace(order=linear.order)
        before = {s.name: s.nrmse for s in validate(linear, segments)}
    print(f"\nLevel {level}, first search: each re-identified effect, its guards and its held-out errors "
          "(NRMSE after / before, fitted band; the records are never used by the loop)")
    print("| effect | log BF | quality index | κ | M | status: reason | " + " | ".join(before) + " |")
    print("| --- | --- | --- | --- | --- | --- | " + "--- | " * len(before))
    for row in results.get("loop_scores", [[]])[0]:
        if row.get("log_evidence_laplace") is None:
            continue
        at = tuple(row["at"])
        term = Term(row["term"].rsplit("@", 1)[0], at if len(at) == 2 else at[0])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reading = MisfitReading()
            try:
                trial = identify(signals, CandidateModel("trial", (term,)), nsi)
                reading = misfit_reading(trial, signals, seed=config.evidence.seed)
                errors = {s.name: s.nrmse for s in validate(trial, segments)}
            except Exception as err:  # noqa: BLE001 - a table row, whatever failed
                errors = {name: None for name in before} | {"error": str(err)[:40]}
        cells = " | ".join("diverged" if errors.get(n) is None else f"{errors[n] / before[n]:.2f}" for n in before)
        print(f"| {row['term'][:48]} | {row['log_bayes_factor']:.0f} | {row['imag_ratio']:.2f} | "
              f"{reading.misfit_ratio:.3g} | {reading.resolution:.3g} | {row['status']}: {row['reason'][:60]} | "
              f"{cells} |")


def _figure_of_merit_table(level: int, added) -> None:
    config = load_config(CONFIGS[level])
    terms = tuple(Term(a["expr"], tuple(a["at"]) if isinstance(a["at"], list) else a["at"]) for a in added)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        signals = load_signals(config)
        models = {"linear": identify(signals, CandidateModel("linear", ()), config.nsi.replace(order="auto"))}
        models["after the loop"] = identify(signals, CandidateModel("loop", terms),
                                            config.nsi.replace(order=models["linear"].order))
    print(f"\nFigure of merit, level {level} model: rms simulation error per output [m/s²] on the fitted band "
          "(2-15 Hz) / over the whole measured signal; signal rms for scale")
    print("| record | model | sensor 1 | sensor 2 | sensor 3 |")
    print("| --- | --- | --- | --- | --- |")
    for other in [lv for lv in (1, 3, 5) if lv != level] + ["odd1", "odd2", "odd3"]:
        if isinstance(other, int):
            segment, record, period = f"full multisine level {other}", full(other), PERIOD
        else:
            segment, record, period = f"random-odd level {other[-1]}", odd(int(other[-1])), ODD_PERIOD
        for name, result in models.items():
            try:
                band, whole, rms = figure_of_merit(result, segment, level, record, period)
            except Exception as err:  # noqa: BLE001 - a table row, whatever failed (no steady state)
                print(f"| {segment} | {name} | failed: {str(err)[:60]} | | |")
                continue
            print(f"| {segment} | {name} | " + " | ".join(f"{b:.4f} / {w:.4f} ({r:.3f})" for b, w, r in
                                                          zip(band, whole, rms)) + " |")


def run(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--steps", nargs="+", choices=STEPS, default=list(STEPS))
    args = parser.parse_args(argv)
    if not DATA.is_dir():
        print(f"the F-16 data are not at {DATA}; see workflows/README.md", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if "bla" in args.steps:
        step_bla()
    if "linear" in args.steps:
        step_linear()
    if "modes" in args.steps:
        step_modes()
    if "diagnose" in args.steps:
        step_diagnose(out)
    return 0


if __name__ == "__main__":
    sys.exit(run())
