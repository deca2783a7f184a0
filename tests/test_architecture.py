"""Checks that keep the architecture of bayesnsi (docs/architecture.md): the import graph and the names.

Static analysis of the source with :mod:`ast`, nothing imported: no import cycles, the layers,
module size, the parameter count of the entry points; no blanket warning filter, no file or test
named after how it came about, the tests laid out by package. The rules on the public API (docstrings,
option names, what scripts import) are in ``test_api_rules.py``. Each test names every offender.
"""

from __future__ import annotations

import ast
import dataclasses
import re
import sys
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "bayesnsi"
MAX_MODULE_LINES = 450
MAX_ENTRY_POINT_PARAMETERS = 6
ENTRY_POINTS = ("identify", "close_the_loop", "select", "diagnose")

# Modules every layer may use (settings, errors, the signal container, shared helpers); the
# private top-level modules (``bayesnsi._dispatch``, ``bayesnsi._fingerprint``, ...) are shared too.
SHARED_PUBLIC = ("options", "exceptions", "signals", "preprocess", "findings")
# Packages of the numerical core and the bayesnsi packages each may import besides the shared modules.
CORE_ALLOWED = {
    "models": (),
    "noise": (),
    "nsi": ("models", "noise"),
    "simulate": ("models",),
    "evidence": ("nsi", "models", "noise"),
    "checks": ("evidence", "nsi", "models", "noise"),  # model checks beside the evidence
    "uncertainty": ("checks", "evidence", "nsi", "models", "noise"),  # re-identification uncertainty, widening
    "loop": ("checks", "evidence", "nsi", "models", "noise"),
}
# Third-party packages allowed in the numpy/scipy-only layers (the standard library always is).
NUMERICAL_ONLY = ("models", "noise", "nsi", "simulate")
NUMERICAL_THIRD_PARTY = frozenset({"numpy", "scipy"})


# --------------------------------------------------------------------------------------------
# The import graph
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Import:
    """One import statement's target, as seen from the module that holds it."""

    source: str
    target: str
    line: int
    type_only: bool  # under ``if TYPE_CHECKING:`` (not executed at run time)


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@cache
def _sources() -> dict[str, Path]:
    """Module name -> file, for every module of bayesnsi."""
    return {_module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}


@cache
def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def is_shared(module: str) -> bool:
    """Whether a module is a shared leaf every layer may import."""
    parts = module.split(".")
    return len(parts) == 2 and (parts[1] in SHARED_PUBLIC or (parts[1].startswith("_") and parts[1] != "__main__"))


def _is_package(module: str) -> bool:
    return _sources()[module].name == "__init__.py"


def _resolve_from(module: str, node: ast.ImportFrom) -> str:
    """Absolute name of the module an ``ImportFrom`` reads from (relative levels resolved)."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if _is_package(module) else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _type_checking_lines(tree: ast.Module) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                lines.update(range(child.lineno, (child.end_lineno or child.lineno) + 1))
    return lines


def _raw_imports(module: str, tree: ast.Module) -> Iterator[tuple[str, str | None, int]]:
    """Imports anywhere in a module (also inside functions): (module read, name taken or None, line)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, None, node.lineno
        elif isinstance(node, ast.ImportFrom):
            origin = _resolve_from(module, node)
            for alias in node.names:
                yield origin, (None if alias.name == "*" else alias.name), node.lineno
        elif (
            isinstance(node, ast.Call)
            and ast.unparse(node.func) in ("importlib.import_module", "import_module", "__import__")
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            yield node.args[0].value, None, node.lineno


def _target(origin: str, name: str | None) -> str:
    """The bayesnsi module an import lands in.

    ``from bayesnsi.nsi import identify`` takes the function the package ``bayesnsi.nsi``
    exports (so the package), ``from bayesnsi.nsi import _hankel`` a submodule the package does
    not bind (so the submodule).
    """
    modules = _sources()
    if name is not None and origin in modules:
        submodule = f"{origin}.{name}"
        if submodule in modules and not (_is_package(origin) and _binds_non_module(origin, name)):
            return submodule
        return origin
    parts = origin.split(".")
    for end in range(len(parts), 0, -1):
        if ".".join(parts[:end]) in modules:
            return ".".join(parts[:end])
    return origin


def _binds_non_module(package: str, name: str) -> bool:
    """Whether ``package`` binds ``name`` to something other than its submodule of that name."""
    for node in _tree(_sources()[package]).body:
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if (alias.asname or alias.name) == name:
                    return not (_resolve_from(package, node) == package and alias.name == name)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.name == name:
            return True
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                return True
    return False


@cache
def import_graph() -> tuple[Import, ...]:
    """Every import of a bayesnsi module by a bayesnsi module."""
    edges = []
    for module, path in _sources().items():
        tree = _tree(path)
        typing_lines = _type_checking_lines(tree)
        for origin, name, line in _raw_imports(module, tree):
            if _in(origin, "bayesnsi"):
                target = _target(origin, name)
                if target != module:
                    edges.append(Import(module, target, line, line in typing_lines))
    return tuple(edges)


@cache
def third_party_imports() -> tuple[tuple[str, str, int], ...]:
    """(module, top-level package, line) of every import outside bayesnsi and the stdlib."""
    found = []
    for module, path in _sources().items():
        for origin, _name, line in _raw_imports(module, _tree(path)):
            top = origin.split(".")[0]
            if top and top != "bayesnsi" and top not in sys.stdlib_module_names and top != "__future__":
                found.append((module, top, line))
    return tuple(found)


def _in(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _where(edge: Import) -> str:
    return f"{edge.source} (line {edge.line}) imports {edge.target}"


def find_cycle(edges) -> list[str] | None:
    """One import cycle of the graph as [a, b, ..., a], or None."""
    graph: dict[str, set[str]] = {}
    for edge in edges:
        graph.setdefault(edge.source, set()).add(edge.target)
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state:
            found = visit(start)
            if found:
                return found
    return None


def all_cycles(edges) -> list[list[str]]:
    """The strongly connected components with more than one module (each holds a cycle)."""
    graph: dict[str, set[str]] = {}
    for edge in edges:
        graph.setdefault(edge.source, set()).add(edge.target)
        graph.setdefault(edge.target, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components = []

    def strongconnect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in graph[node]:
            if nxt not in index:
                strongconnect(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            strongconnect(node)
    return components


# --------------------------------------------------------------------------------------------
# a. no import cycles
# --------------------------------------------------------------------------------------------


def test_cycle_finder_finds_a_cycle():
    edges = [Import(a, b, 1, False) for a, b in (("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"))]
    assert find_cycle(edges) == ["a", "b", "c", "a"]
    assert all_cycles(edges) == [["a", "b", "c"]]
    assert find_cycle(edges[:2]) is None


def test_graph_resolves_relative_and_function_level_imports():
    def origin(module: str, statement: str) -> str:
        node = ast.parse(statement).body[0]
        assert isinstance(node, ast.ImportFrom)
        return _resolve_from(module, node)

    assert origin("bayesnsi.nsi.identify", "from ..exceptions import ConfigError") == "bayesnsi.exceptions"
    assert origin("bayesnsi.nsi", "from .identify import identify") == "bayesnsi.nsi.identify"
    assert origin("bayesnsi.nsi.identify", "from . import _hankel") == "bayesnsi.nsi"
    # a name the package exports lands in the package, a submodule it does not bind in the submodule
    assert _target("bayesnsi.nsi", "identify") == "bayesnsi.nsi"
    assert _target("bayesnsi.nsi", "_hankel") == "bayesnsi.nsi._hankel"
    assert _target("bayesnsi.nsi.identify", "identify") == "bayesnsi.nsi.identify"
    # imports inside functions are in the graph
    nested = {
        (module, node.lineno)
        for module, path in _sources().items()
        for function in ast.walk(_tree(path)) if isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef))
        for node in ast.walk(function) if isinstance(node, ast.ImportFrom) and node.level > 0
    }
    assert nested and nested <= {(e.source, e.line) for e in import_graph()} | {
        (m, n) for m, n in nested if _target_self(m, n)
    }


def _target_self(module: str, line: int) -> bool:
    """Whether the import at ``line`` of ``module`` reads from the module itself (no edge)."""
    for node in ast.walk(_tree(_sources()[module])):
        if isinstance(node, ast.ImportFrom) and node.lineno == line:
            return all(_target(_resolve_from(module, node), a.name) == module for a in node.names)
    return False


def test_no_import_cycles():
    runtime = [e for e in import_graph() if not e.type_only]
    components = all_cycles(runtime)
    if components:
        cycle = find_cycle(runtime)
        lines = {_where(e) for e in runtime if any(e.source in c and e.target in c for c in components)}
        pytest.fail(
            f"import cycle {' -> '.join(cycle or [])}; modules in cycles: {components}; imports among them:\n  "
            + "\n  ".join(sorted(lines))
        )


# --------------------------------------------------------------------------------------------
# b. layering
# --------------------------------------------------------------------------------------------


def _layer_violations(rule) -> list[str]:
    """Run-time imports that break ``rule`` (an annotation under ``if TYPE_CHECKING:`` is not a dependency)."""
    return sorted({_where(e) for e in import_graph() if not e.type_only and rule(e.source, e.target)})


def test_cli_is_imported_only_by_cli():
    offenders = _layer_violations(
        lambda s, t: _in(t, "bayesnsi.cli") and not (_in(s, "bayesnsi.cli") or s == "bayesnsi.__main__")
    )
    assert not offenders, "bayesnsi.cli is the top layer; nothing else imports it:\n" + "\n".join(offenders)


def test_core_does_not_import_io_or_run():
    core = [f"bayesnsi.{name}" for name in CORE_ALLOWED]
    offenders = _layer_violations(
        lambda s, t: any(_in(s, c) for c in core) and (_in(t, "bayesnsi.io") or _in(t, "bayesnsi.run"))
    )
    assert not offenders, "the numerical core must not import io or run:\n" + "\n".join(offenders)


def test_plots_and_report_are_imported_only_at_the_edge():
    # figures are drawn by the report and the command line; the report is written by the command line
    importers = {"bayesnsi.plots": ("bayesnsi.plots", "bayesnsi.report", "bayesnsi.cli"),
                 "bayesnsi.report": ("bayesnsi.report", "bayesnsi.cli")}

    def wrong(source: str, target: str) -> bool:
        layer = next((layer for layer in importers if _in(target, layer)), None)
        return layer is not None and not any(_in(source, ok) for ok in importers[layer])

    offenders = _layer_violations(wrong)
    assert not offenders, "only the report and the command line draw figures:\n" + "\n".join(offenders)


def test_run_and_io_are_imported_only_from_above():
    # io (files) only by plots, the report and cli: the run layer takes its cache as an injected object;
    # run by the workflows (selection, diagnosis), io (which rebuilds the run's outcome objects from cache
    # entries), the report and cli
    importers = {
        "bayesnsi.io": ("bayesnsi.io", "bayesnsi.plots", "bayesnsi.report", "bayesnsi.cli"),
        "bayesnsi.run": ("bayesnsi.run", "bayesnsi.selection", "bayesnsi.diagnosis", "bayesnsi.io", "bayesnsi.report",
                         "bayesnsi.cli"),
    }

    def wrong(source: str, target: str) -> bool:
        layer = next((layer for layer in importers if _in(target, layer)), None)
        return layer is not None and not any(_in(source, ok) for ok in importers[layer])

    offenders = _layer_violations(wrong)
    assert not offenders, "io and run sit above the library:\n" + "\n".join(offenders)


def test_core_packages_import_only_lower_layers():
    def wrong(source: str, target: str) -> bool:
        for name, allowed in CORE_ALLOWED.items():
            package = f"bayesnsi.{name}"
            if _in(source, package) and not _in(target, package):
                ok = is_shared(target) or any(_in(target, f"bayesnsi.{a}") for a in allowed)
                return not ok
        return False

    offenders = _layer_violations(wrong)
    assert not offenders, f"core layers and what they may import {CORE_ALLOWED} (+ shared):\n" + "\n".join(offenders)


def test_shared_modules_import_only_shared_modules():
    offenders = _layer_violations(lambda s, t: is_shared(s) and not is_shared(t))
    assert not offenders, "options, exceptions, signals, ... are leaves every layer uses:\n" + "\n".join(offenders)


def test_numerical_layers_use_only_numpy_and_scipy():
    offenders = sorted(
        f"{module} (line {line}) imports {top}"
        for module, top, line in third_party_imports()
        if any(_in(module, f"bayesnsi.{name}") for name in NUMERICAL_ONLY) and top not in NUMERICAL_THIRD_PARTY
    )
    assert not offenders, "models, nsi and simulate use numpy/scipy only:\n" + "\n".join(offenders)


def test_drawing_and_sampling_libraries_stay_in_their_packages():
    # figures are drawn and encoded in plots only (the report arranges them); the sampler lives in
    # evidence, the posterior summaries there and in their figures
    plots, evidence = ("bayesnsi.plots",), ("bayesnsi.evidence",)
    homes = {"matplotlib": plots, "emcee": evidence, "arviz": evidence + plots, "arviz_base": evidence + plots,
             "arviz_stats": evidence + plots, "arviz_plots": plots}
    offenders = sorted(
        f"{module} (line {line}) imports {top}"
        for module, top, line in third_party_imports()
        if top in homes and not any(_in(module, home) for home in homes[top])
    )
    assert not offenders, "matplotlib only in plots, emcee in evidence, arviz in evidence and plots:\n" + "\n".join(
        offenders)


# --------------------------------------------------------------------------------------------
# c. module size
# --------------------------------------------------------------------------------------------


def test_modules_are_short():
    sizes = {module: len(path.read_text(encoding="utf-8").splitlines()) for module, path in _sources().items()}
    offenders = sorted(f"{m}: {n} lines" for m, n in sizes.items() if n > MAX_MODULE_LINES)
    assert not offenders, f"modules over {MAX_MODULE_LINES} lines:\n" + "\n".join(offenders)


# --------------------------------------------------------------------------------------------
# e. entry points stay small
# --------------------------------------------------------------------------------------------


def _parameter_count(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    args = node.args
    names = [a.arg for a in args.posonlyargs + args.args + args.kwonlyargs]
    names += [a.arg for a in (args.vararg, args.kwarg) if a is not None]
    return len(names[1:] if names and names[0] in ("self", "cls") else names)


def test_entry_points_take_few_parameters():
    offenders = []
    for module, path in _sources().items():
        for node in ast.walk(_tree(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in ENTRY_POINTS:
                count = _parameter_count(node)
                if count > MAX_ENTRY_POINT_PARAMETERS:
                    offenders.append(f"{module}.{node.name} (line {node.lineno}): {count} parameters")
    assert not offenders, (
        f"{ENTRY_POINTS} take at most {MAX_ENTRY_POINT_PARAMETERS} parameters (group settings in options):\n"
        + "\n".join(offenders)
    )


# --------------------------------------------------------------------------------------------
# f. names by concept, one warning filtered at a time, tests laid out by package
# --------------------------------------------------------------------------------------------

TESTS = ROOT / "tests"
SCRIPTS = (PACKAGE, TESTS, ROOT / "benchmarks", ROOT / "workflows", ROOT / "notebooks")
# how a thing came about is not what it is: no file or test is named after its issue or its trial
HISTORY_WORDS = ("trial", "issue")
HISTORY_TEXT = re.compile(r"\bissue[- ]?\d+|\btrial\b", re.IGNORECASE)


def _python_files(*folders: Path) -> list[Path]:
    paths = (p for folder in folders if folder.is_dir() for p in folder.rglob("*.py"))
    return sorted(p for p in paths if "__pycache__" not in p.parts)


def history_names(paths) -> list[str]:
    """Files, test functions and test docstrings of ``paths`` that name how they came about (HISTORY_WORDS)."""
    offenders = []
    for path in paths:
        where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
        if any(word in path.stem.lower() for word in HISTORY_WORDS):
            offenders.append(f"{where}: file name")
        if not path.name.startswith("test_"):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name.startswith("test"):
                if any(word in node.name.lower() for word in HISTORY_WORDS):
                    offenders.append(f"{where}:{node.lineno}: test {node.name}")
            if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                doc = ast.get_docstring(node)
                if doc and HISTORY_TEXT.search(doc):
                    line = getattr(node, "lineno", 1)
                    offenders.append(f"{where}:{line}: docstring cites {HISTORY_TEXT.search(doc).group(0)!r}")
    return offenders


def _text(node: ast.expr | None) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def blanket_ignores(tree: ast.AST) -> list[int]:
    """Lines of ``tree`` that ignore every warning category: ``warnings.simplefilter("ignore")``,
    ``warnings.filterwarnings("ignore", ...)`` without a category, ``pytest.mark.filterwarnings("ignore")``
    or ``"ignore:message"`` without a category."""
    lines = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
        if name not in ("simplefilter", "filterwarnings"):
            continue
        keywords = {k.arg: k.value for k in node.keywords}
        action = _text(node.args[0] if node.args else keywords.get("action"))
        on_mark = isinstance(func, ast.Attribute) and getattr(func.value, "attr", None) == "mark"  # pytest.mark
        if on_mark:  # "action:message:category:module:lineno"
            fields = [*(action or "").split(":"), "", ""]
            blanket = fields[0].strip() == "ignore" and not fields[2].strip()
        else:
            category_at = 1 if name == "simplefilter" else 2
            blanket = action == "ignore" and len(node.args) <= category_at and "category" not in keywords
        if blanket:
            lines.append(node.lineno)
    return lines


def test_blanket_ignore_finder_finds_every_form():
    source = """
warnings.simplefilter("ignore")
warnings.simplefilter(action="ignore")
warnings.filterwarnings("ignore", message="x")
@pytest.mark.filterwarnings("ignore")
@pytest.mark.filterwarnings("ignore:a message")
def f(): pass
warnings.simplefilter("ignore", UserWarning)
warnings.simplefilter("always")
warnings.filterwarnings("ignore", "x", UserWarning)
warnings.filterwarnings("ignore", message="x", category=UserWarning)
@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.filterwarnings("ignore:a message:bayesnsi.exceptions.IntegrationWarning")
def g(): pass
"""
    assert blanket_ignores(ast.parse(source)) == [2, 3, 4, 5, 6]


def test_no_blanket_warning_filter_in_the_package_or_the_tests():
    """filterwarnings = error holds: each filter names the one warning category it silences."""
    offenders = [f"{path.relative_to(ROOT)}:{line}" for path in _python_files(PACKAGE, TESTS)
                 for line in blanket_ignores(_tree(path))]
    assert not offenders, "filter the one warning provoked (category, and message where useful):\n" + "\n".join(
        offenders)


def test_history_finder_finds_files_tests_and_docstrings(tmp_path):
    named = tmp_path / "test_trial_rig.py"
    named.write_text('"""Issue 14: the rig."""\n\ndef test_meets_the_issue_17_accuracy():\n    """A trial rig."""\n')
    found = history_names([named])
    assert [f.split(": ", 1)[1] for f in found] == [
        "file name", "docstring cites 'Issue 14'", "test test_meets_the_issue_17_accuracy", "docstring cites 'trial'"]
    plain = tmp_path / "test_rig.py"
    plain.write_text('"""The rig: 40 trials of one lock."""\n\ndef test_trial_step_of_the_fit_is_kept():\n    pass\n')
    assert [f.split(": ", 1)[1] for f in history_names([plain])] == ["test test_trial_step_of_the_fit_is_kept"]


def test_files_and_tests_are_named_by_concept_not_by_history():
    offenders = history_names(_python_files(*SCRIPTS))
    assert not offenders, "name files and tests by the concept they hold or check:\n" + "\n".join(offenders)


def test_tests_are_laid_out_by_package():
    """tests/<package>/ for each package's tests; what several folders share lives in tests/_helpers or
    tests/conftest.py, never imported from another folder's test file."""
    packages = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    folders = {p.name for p in TESTS.iterdir() if p.is_dir() and p.name not in ("__pycache__", "_helpers")}
    assert folders <= packages, f"test folders not named after a package: {sorted(folders - packages)}"
    assert len(folders) >= 5
    assert all((TESTS / folder / "__init__.py").is_file() for folder in folders)
    offenders = []
    for path in _python_files(TESTS):
        here = path.parent.relative_to(ROOT).parts
        for node in ast.walk(_tree(path)):
            if isinstance(node, ast.ImportFrom):
                base = here[: len(here) - node.level + 1] if node.level else ()
                parts = (*base, *(node.module or "").split("."))
                if parts[-1].startswith("test_") and tuple(parts[:-1]) != here:
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}: {'.'.join(parts)}")
    assert not offenders, "imports of another folder's test file (move the helper to tests/_helpers):\n" + "\n".join(
        offenders)
