"""What a user meets first: --version, a fast --help, compact reprs, the state-space export."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import signal as sps

import bayesnsi
from bayesnsi import NSIOptions, identify, simulate_case
from bayesnsi.cli import main


@pytest.fixture(scope="module")
def two_dof_result():
    case = simulate_case("two-dof", seed=0)
    return identify(case.signals, case.candidates[0], NSIOptions(block_rows=60, order=4))


def _frf_from_transfer_functions(ss, freqs_hz):
    """H(e^{jωdt}) from the transfer-function polynomials of each input (scipy.signal.ss2tf), not the modal form."""
    z = np.exp(2j * np.pi * np.asarray(freqs_hz) * ss.dt)
    columns = []
    for j in range(ss.B.shape[1]):
        num, den = sps.ss2tf(ss.A, ss.B, ss.C, ss.D, input=j)
        columns.append(np.stack([np.polyval(row, z) for row in num], axis=1) / np.polyval(den, z)[:, None])
    return np.stack(columns, axis=2)


def test_to_statespace_reproduces_the_underlying_frf(two_dof_result):
    ss = two_dof_result.to_statespace()
    assert isinstance(ss, sps.StateSpace)
    assert ss.dt == pytest.approx(two_dof_result.model.dt)
    assert ss.B.shape == (4, len(two_dof_result.input_dofs))  # the force columns only, no term inputs
    freqs = np.linspace(0.2, 20.0, 120)
    expected = two_dof_result.underlying_frf(freqs)
    np.testing.assert_allclose(_frf_from_transfer_functions(ss, freqs), expected, rtol=1e-7, atol=1e-12)
    # and the resolvent by a linear solve at each frequency
    z = np.exp(2j * np.pi * freqs * ss.dt)
    direct = np.stack([ss.C @ np.linalg.solve(zk * np.eye(4) - ss.A, ss.B) + ss.D for zk in z])
    np.testing.assert_allclose(direct, expected, rtol=1e-8, atol=1e-14)


def test_to_statespace_python_control(two_dof_result):
    control = pytest.importorskip("control", reason="python-control is optional (pip install control)")
    s = two_dof_result.to_statespace()
    sys_c = control.ss(s.A, s.B, s.C, s.D, s.dt)  # the recipe of the docstring
    assert isinstance(sys_c, control.StateSpace) and sys_c.dt == pytest.approx(two_dof_result.model.dt)
    freqs = np.array([1.0, 2.46, 7.5, 15.0])
    h = sys_c(np.exp(2j * np.pi * freqs * sys_c.dt))  # (outputs, inputs, freqs)
    np.testing.assert_allclose(np.moveaxis(h, -1, 0), two_dof_result.underlying_frf(freqs), rtol=1e-8)


def test_result_reprs_are_compact(two_dof_result):
    text = repr(two_dof_result)
    assert text.startswith("NSIResult(candidate='model 1', order=4") and "array(" not in text and len(text) < 300
    case = simulate_case("two-dof", seed=0)
    rec = repr(two_dof_result.reconstruct(case.signals))
    assert rec.startswith("Reconstruction(") and "<array 1000x2>" in rec and len(rec) < 200


def test_version_flag(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"bayesnsi {bayesnsi.__version__}"


def test_help_imports_no_numerical_library():
    """`bayesnsi --help` stays fast (benchmarks/cli_startup.py: ~0.06 s) because the parser imports neither
    numpy, scipy, pandas nor matplotlib; the numerical names of `bayesnsi` load on first use."""
    code = (
        "import sys\nfrom bayesnsi.cli import build_parser\nbuild_parser().format_help()\n"
        "print(sorted(m for m in ('numpy', 'scipy', 'pandas', 'matplotlib') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_lazy_top_level_names_are_the_real_objects():
    from bayesnsi.nsi import identify as nsi_identify

    assert bayesnsi.identify is nsi_identify and "identify" in dir(bayesnsi)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        bayesnsi.nope  # noqa: B018


PUBLIC = ("bayesnsi", "bayesnsi.nsi", "bayesnsi.evidence", "bayesnsi.loop", "bayesnsi.models", "bayesnsi.simulate",
          "bayesnsi.io", "bayesnsi.run", "bayesnsi.plots", "bayesnsi.options", "bayesnsi.selection")


def _public_docstrings():
    import importlib
    import inspect

    for name in PUBLIC:
        module = importlib.import_module(name)
        yield name, module.__doc__ or ""
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{name}.{attr}", obj.__doc__ or ""
                for member, value in vars(obj).items() if inspect.isclass(obj) else ():
                    if not member.startswith("_") and (inspect.isfunction(value) or isinstance(value, property)):
                        yield f"{name}.{attr}.{member}", value.__doc__ or ""


def test_docstrings_and_help_cite_no_private_spec():
    """Users have the paper and docs/, not the project's spec: `help()` and `--help` point to docs/method.md."""
    import argparse
    import re

    from bayesnsi.cli import build_parser

    pattern = re.compile(r"\bSPEC\b|\bspec section|\.\./shared")
    offenders = [name for name, doc in _public_docstrings() if pattern.search(doc)]
    parser = build_parser()
    helps = {"bayesnsi": parser.format_help()}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps |= {f"bayesnsi {c}": sub.format_help() for c, sub in action.choices.items()}
    offenders += [name for name, text in helps.items() if pattern.search(text)]
    assert not offenders, offenders
    cited = {int(s) for _, doc in _public_docstrings() for s in re.findall(r"docs/method\.md §(\d+)", doc)}
    method = (Path(__file__).resolve().parents[1] / "docs" / "method.md").read_text(encoding="utf-8")
    assert cited and all(f"## §{k} " in method for k in cited), sorted(cited)


def test_documents_cite_no_private_spec():
    """README, docs/, workflows/ and notebooks/ guides point to docs/method.md, not to a spec users do not have."""
    import re

    root = Path(__file__).resolve().parents[1]
    pages = [root / "README.md", *sorted((root / "docs").glob("*.md")), root / "workflows" / "README.md",
             root / "notebooks" / "README.md"]
    offenders = [p.name for p in pages if p.is_file() and re.search(r"\bSPEC\b", p.read_text(encoding="utf-8"))]
    assert not offenders, offenders


def test_loop_settings_are_command_line_flags():
    from bayesnsi.cli import build_parser
    from bayesnsi.cli._common import option_overrides
    from bayesnsi.options import LoopOptions

    args = build_parser().parse_args([
        "diagnose", "c.toml", "--out", "o", "--stability-factor", "2.5", "--n-tries", "5", "--max-imag-ratio", "0.2",
        "--residual", "innovations", "--refine-final", "none",
    ])
    options = option_overrides(LoopOptions(threshold=3.0), args)
    assert (options.stability_factor, options.n_tries, options.max_imag_ratio) == (2.5, 5, 0.2)
    assert options.residual == "innovations" and options.refine_final is None
    assert options.threshold == 3.0  # a flag not given keeps the config's value


def test_to_statespace_of_a_free_body_has_its_virtual_spring_removed(two_dof_result):
    import dataclasses

    spring = dataclasses.replace(two_dof_result, options=two_dof_result.options.replace(virtual_stiffness=300.0))
    freqs = np.linspace(0.2, 20.0, 60)
    ss = spring.to_statespace()
    np.testing.assert_allclose(_frf_from_transfer_functions(ss, freqs), spring.underlying_frf(freqs), rtol=1e-6)
    assert not np.allclose(spring.underlying_frf(freqs), two_dof_result.underlying_frf(freqs))  # the spring matters
