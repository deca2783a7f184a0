"""The notebooks run end to end (tiny-data mode), and each .ipynb matches its jupytext script."""

import json
import shutil
from pathlib import Path

import pytest

jupytext = pytest.importorskip("jupytext")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

pytestmark = pytest.mark.notebooks

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
SCRIPTS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))
TIMEOUT_S = 600  # per cell; a tiny-data run takes seconds


def execute(script: Path, workdir: Path):
    """Run a jupytext script as a notebook in ``workdir`` with the tiny-data switch on."""
    notebook = jupytext.read(script)
    client = nbclient.NotebookClient(
        notebook, timeout=TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": str(workdir)}}
    )
    client.execute()
    return notebook


def stderr_outputs(notebook) -> list[str]:
    """Text written to stderr by any cell (warnings included)."""
    return [
        out["text"]
        for cell in notebook.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "stream" and out.get("name") == "stderr"
    ]


def cells(notebook) -> list[tuple[str, str]]:
    """(type, source) of every cell, the comparison jupytext's round trip preserves."""
    return [(cell.cell_type, cell.source.strip()) for cell in notebook.cells]


@pytest.fixture
def small(monkeypatch, tmp_path_factory):
    """Tiny-data switch on, one BLAS thread, and a ``python3`` kernel on this interpreter.

    The kernelspec in a private JUPYTER_PATH entry (searched first) shadows any user-level
    ``python3`` kernel that points at another Python; jupyter_client runs ``python`` as
    ``sys.executable``.
    """
    kernels = tmp_path_factory.mktemp("jupyter")
    spec = kernels / "kernels" / "python3"
    spec.mkdir(parents=True)
    argv = ["python", "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    (spec / "kernel.json").write_text(json.dumps({"argv": argv, "display_name": "Python 3", "language": "python"}))
    monkeypatch.setenv("JUPYTER_PATH", str(kernels))
    monkeypatch.setenv("BAYESNSI_NOTEBOOK_SMALL", "1")
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.setenv(name, "1")


def test_four_notebooks_present():
    assert [p.stem[:2] for p in SCRIPTS] == ["01", "02", "03", "04"]


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_notebook_runs(script, small):
    notebook = execute(script, NOTEBOOKS)
    assert stderr_outputs(notebook) == []


def test_silverbox_notebook_skips_without_data(small, tmp_path):
    """Outside the repository (no config, no data) the Silverbox notebook says so and stops."""
    script = shutil.copy(NOTEBOOKS / "03_silverbox_closing_the_loop.py", tmp_path)
    notebook = execute(Path(script), tmp_path)
    printed = "".join(
        out.get("text", "") for cell in notebook.cells if cell.cell_type == "code" for out in cell.get("outputs", [])
    )
    assert "SKIPPED" in printed
    assert stderr_outputs(notebook) == []


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_ipynb_in_sync_with_script(script):
    paired = script.with_suffix(".ipynb")
    assert paired.is_file(), f"{paired.name} missing: run `jupytext --to ipynb {script.name}` in notebooks/"
    from_script = jupytext.read(script)
    from_ipynb = jupytext.read(paired)
    stale = f"{paired.name} is out of date: run `jupytext --sync {script.name}` in notebooks/"
    assert cells(from_ipynb) == cells(from_script), stale
    for cell in from_ipynb.cells:  # committed without outputs
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None
