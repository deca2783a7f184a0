"""Rules on the public API of bayesnsi (docs/architecture.md): docstrings, option names, scripts.

These import the package to read ``__all__``, the option dataclasses, the config loader and the
command line parser; the import graph checks are in ``test_architecture.py``. Each test names
every offender it finds.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import re
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from .test_architecture import PACKAGE, ROOT, _in, _sources, _tree

PUBLIC_MODULES = (
    "bayesnsi", "bayesnsi.nsi", "bayesnsi.evidence", "bayesnsi.loop", "bayesnsi.models",
    "bayesnsi.simulate", "bayesnsi.io", "bayesnsi.run", "bayesnsi.plots", "bayesnsi.options",
    "bayesnsi.selection", "bayesnsi.tables",
)


# --------------------------------------------------------------------------------------------
# d. numpydoc docstrings of the public API
# --------------------------------------------------------------------------------------------

_SECTION = re.compile(r"^(\w[\w ]*)\n-{3,}\s*$", re.MULTILINE)


def docstring_problems(obj) -> list[str]:
    """What a public function's or class's docstring lacks (numpydoc: summary, sections)."""
    doc = _own_doc(obj)
    if not doc:
        return ["no docstring"]
    problems = []
    lines = doc.splitlines()
    if not lines[0].strip().endswith("."):
        problems.append("summary does not end with a period")
    if len(lines) > 1 and lines[1].strip():
        problems.append("summary is longer than one line")
    function = _documented_callable(obj)
    if function is None:
        return problems
    if inspect.isclass(obj):  # numpydoc allows the parameters in the class or the __init__ docstring
        doc += "\n\n" + (_own_doc(function) or "")
    sections = {match.group(1).strip() for match in _SECTION.finditer(doc)}
    if _parameters(function) and "Parameters" not in sections:
        problems.append("no Parameters section")
    if not inspect.isclass(obj) and _returns_value(function):
        if "Returns" not in sections and "Yields" not in sections:
            problems.append("no Returns section")
    return problems


def _own_doc(obj) -> str | None:
    """The object's own docstring, cleaned (not a base class's, nor the one dataclass generates)."""
    doc = obj.__doc__
    if not doc or (inspect.isclass(obj) and dataclasses.is_dataclass(obj) and doc.startswith(f"{obj.__name__}(")):
        return None
    return inspect.cleandoc(doc)


def _documented_callable(obj):
    """The function whose parameters the docstring documents (a class: its own ``__init__``)."""
    if inspect.isclass(obj):
        init = obj.__dict__.get("__init__")
        if init is None or dataclasses.is_dataclass(obj) and "__init__" not in _class_source_defs(obj):
            return None
        return init
    return inspect.unwrap(obj) if inspect.isfunction(inspect.unwrap(obj)) else None


def _class_source_defs(cls) -> set[str]:
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError, SyntaxError):
        return set()
    return {node.name for node in tree.body[0].body if isinstance(node, ast.FunctionDef)}


def _parameters(function) -> list[str]:
    names = list(inspect.signature(function).parameters)
    return names[1:] if names and names[0] in ("self", "cls") else names


def _returns_value(function) -> bool:
    annotation = function.__annotations__.get("return", inspect.Signature.empty)
    if annotation is not inspect.Signature.empty:
        return annotation not in (None, "None", type(None))
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    except (OSError, TypeError, SyntaxError):
        return False
    return any(_own_returns(tree.body[0]))


def _own_returns(function: ast.AST) -> Iterator[bool]:
    """For each return/yield in a function's own body (not nested ones): whether it gives a value."""
    stack = list(ast.iter_child_nodes(function))
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda)):
            continue
        if isinstance(node, ast.Return):
            yield node.value is not None and not (isinstance(node.value, ast.Constant) and node.value.value is None)
        elif isinstance(node, (ast.Yield, ast.YieldFrom)):
            yield True
        stack.extend(ast.iter_child_nodes(node))


def public_objects() -> Iterator[tuple[str, object]]:
    """(qualified name, object) of every function and class in the public modules' ``__all__``."""
    seen = set()
    for module_name in PUBLIC_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError:
            if module_name == "bayesnsi.selection":
                continue
            raise
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name)
            if not (inspect.isfunction(inspect.unwrap(obj)) or inspect.isclass(obj)):
                continue
            if not getattr(obj, "__module__", "").startswith("bayesnsi") or id(obj) in seen:
                continue
            seen.add(id(obj))
            yield f"{obj.__module__}.{obj.__qualname__}", obj


def test_docstring_checker_catches_gaps():
    def undocumented(x, y):
        return x + y

    def documented(x):
        """Double a number.

        Parameters
        ----------
        x : float

        Returns
        -------
        float
        """
        return 2 * x

    def summary_only(x):
        """Print a number"""
        print(x)

    assert docstring_problems(undocumented) == ["no docstring"]
    assert docstring_problems(documented) == []
    assert docstring_problems(summary_only) == ["summary does not end with a period", "no Parameters section"]

    class Inherits(ValueError):
        def __init__(self, message, key):
            """Keep the key.

            Parameters
            ----------
            message, key : str
            """
            super().__init__(message)

    assert docstring_problems(Inherits) == ["no docstring"]  # ValueError's docstring does not count
    Inherits.__doc__ = "An error that names its key."
    assert docstring_problems(Inherits) == []


def test_public_api_has_numpydoc_docstrings():
    offenders = [f"{name}: {', '.join(p)}" for name, obj in public_objects() if (p := docstring_problems(obj))]
    assert not offenders, f"{len(offenders)} public objects lack a numpydoc docstring part:\n" + "\n".join(offenders)


# --------------------------------------------------------------------------------------------
# f. option names live in bayesnsi/options.py only
# --------------------------------------------------------------------------------------------


def _option_classes():
    from bayesnsi.options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions

    return {"nsi": NSIOptions, "evidence": EvidenceOptions, "diagnose": LoopOptions, "execution": ExecutionOptions}


def _config_document(section: str, key: str, value) -> dict:
    document = {
        "data": {"file": "data.csv", "fs": 100.0, "inputs": {"f": 1}, "outputs": {"x": 1}},
        "nsi": {"block_rows": 10, "order": 2},
        "candidates": [{"name": "linear", "terms": []}],
    }
    document.setdefault(section, {})[key] = value
    return document


def _load_table(tmp_path: Path, section: str, key: str, value):
    from bayesnsi.io import dump_config, load_config

    path = tmp_path / f"{section}-{key}.toml"
    path.write_text(dump_config(_config_document(section, key, value)), encoding="utf-8")
    return load_config(path, check_files=False)


def _sample_value(options_class, name: str):
    """A valid value of an option that TOML can hold: its default, or one built from its check."""
    value = getattr(options_class(), name)
    if value is None:
        meta = next(item.metadata for item in dataclasses.fields(options_class) if item.name == name)
        low = meta.get("low") or 0
        value = {
            "band": [1.0, 10.0], "int": int(low) + 1, "float": float(low) + 1.0,
            "choice": (meta.get("choices") or (None,))[0],
        }.get(meta.get("kind"))
    return list(value) if isinstance(value, tuple) else value


@pytest.mark.parametrize("section", ["nsi", "evidence", "diagnose"])
def test_config_tables_accept_exactly_the_option_fields(tmp_path, section):
    from bayesnsi.exceptions import ConfigError

    options_class = _option_classes()[section]
    attribute = {"nsi": "nsi", "evidence": "evidence", "diagnose": "loop"}[section]
    rejected = []
    for name in options_class.names():
        value = _sample_value(options_class, name)
        try:
            config = _load_table(tmp_path, section, name, "?" if value is None else value)
        except ConfigError as err:
            if value is not None or "unknown" in str(err):
                rejected.append(f"[{section}] {name} = {value!r}: {err}")
            continue  # no sample value of this kind: enough that the key is known
        except Exception as err:  # noqa: BLE001 - name the option the loader chokes on
            rejected.append(f"[{section}] {name} = {value!r}: {type(err).__name__}: {err}")
            continue
        loaded = getattr(getattr(config, attribute), name)
        assert loaded == (tuple(value) if isinstance(value, list) else value), (section, name)
    assert not rejected, "option fields the config loader refuses:\n" + "\n".join(rejected)
    with pytest.raises(ConfigError, match="unknown"):
        _load_table(tmp_path, section, "no_such_option", 1)


def test_config_loader_has_no_aliases_of_option_names():
    """The loader reads no key of an options table by a name that is not a field."""
    fields = set().union(*(cls.names() for cls in _option_classes().values()))
    path = PACKAGE / "io" / "config.py"
    offenders = []
    readers = [
        node for node in ast.walk(_tree(path))
        if isinstance(node, ast.FunctionDef) and ("Options" in ast.unparse(node) or "_options(" in ast.unparse(node))
    ]
    for node in (child for reader in readers for child in ast.walk(reader)):
        if isinstance(node, ast.Compare) and isinstance(node.left, ast.Constant) and isinstance(node.left.value, str):
            if any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
                key = node.left.value
                if key not in fields and ast.unparse(node.comparators[0]) == "table":
                    offenders.append(f"io/config.py line {node.lineno}: {ast.unparse(node)}")
    assert not offenders, "option tables read keys that are not option fields (aliases):\n" + "\n".join(offenders)


def _subcommand_actions() -> dict[str, dict[str, list[str]]]:
    """Command -> dest -> option strings of its flags."""
    import argparse

    from bayesnsi.cli import build_parser

    parser = build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {
        command: {a.dest: list(a.option_strings) for a in sub._actions if a.option_strings}
        for command, sub in subparsers.choices.items()
    }


def _cli_fields() -> set[str]:
    """Option fields a flag can spell: all but the objects ExecutionOptions carries (cache, ...)."""
    return {
        item.name for cls in _option_classes().values() for item in dataclasses.fields(cls)
        if item.metadata.get("kind") != "any"
    }


def _cli_objects() -> set[str]:
    execution = dataclasses.fields(_option_classes()["execution"])
    return {item.name for item in execution if item.metadata.get("kind") == "any"}


def _cli_option_assignments() -> list[tuple[str, str, str, int]]:
    """(cli module, option keyword, args attribute, line) where a flag's value sets an option."""
    return [
        (module, keyword, attribute, line)
        for module, path in _sources().items() if _in(module, "bayesnsi.cli")
        for keyword, attribute, line in option_assignments(_tree(path))
    ]


def option_assignments(tree: ast.AST) -> Iterator[tuple[str, str, int]]:
    """(option keyword, args attribute, line) of option-building calls that read a flag."""
    option_calls = {"replace", "from_mapping", *(cls.__name__ for cls in _option_classes().values())}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        if func in option_calls:
            for keyword in node.keywords:
                for attribute in _args_attributes(keyword.value):
                    yield keyword.arg or "**", attribute, node.lineno


def _args_attributes(expression: ast.AST) -> set[str]:
    """Attributes of ``args`` an expression reads (``args.x`` or ``getattr(args, "x", ...)``)."""
    names = set()
    for node in ast.walk(expression):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "args":
            names.add(node.attr)
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "getattr" and len(node.args) >= 2:
            if getattr(node.args[0], "id", "") == "args" and isinstance(node.args[1], ast.Constant):
                names.add(node.args[1].value)
    return names


def test_option_assignment_scanner():
    tree = ast.parse(
        "loop = config.loop.replace(threshold=args.threshold, max_steps=args.most)\n"
        "nsi = NSIOptions(order=getattr(args, 'order', 'auto'), block_rows=40)\n"
        "other = dict(seed=args.seed)\n"
    )
    expected = [("max_steps", "most", 1), ("order", "order", 2), ("threshold", "threshold", 1)]
    assert sorted(option_assignments(tree)) == expected


def test_cli_flags_that_set_options_are_named_after_the_fields():
    fields = _cli_fields()
    actions = _subcommand_actions()
    flags = {dest: strings for by_dest in actions.values() for dest, strings in by_dest.items()}
    assignments = _cli_option_assignments()
    assert assignments, "no command line flag sets an option: the scan of bayesnsi/cli found nothing"
    offenders = []
    for module, keyword, attribute, line in assignments:
        if keyword in _cli_objects():
            continue  # e.g. cache=ResultCache(read=not args.no_cache): an object, not a value
        expected = "--" + keyword.replace("_", "-")
        if keyword not in fields:
            offenders.append(f"{module} line {line}: {keyword}=args.{attribute} is not an option field")
        elif attribute != keyword or expected not in flags.get(attribute, []):
            offenders.append(
                f"{module} line {line}: option {keyword} is set from args.{attribute} "
                f"(flag {flags.get(attribute)}), expected the flag {expected}"
            )
    for command, by_dest in actions.items():
        for dest, strings in by_dest.items():
            if dest in fields and "--" + dest.replace("_", "-") not in strings:
                offenders.append(f"bayesnsi {command}: flag {strings} sets {dest} under another name")
    assert not offenders, "command line flags that set options must be --<field-name>:\n" + "\n".join(offenders)


# --------------------------------------------------------------------------------------------
# g. workflows and notebooks use the public API only
# --------------------------------------------------------------------------------------------


def _script_paths() -> list[Path]:
    return sorted((ROOT / "workflows").glob("*.py")) + sorted((ROOT / "notebooks").glob("*.py"))


def _public_names(module_name: str) -> tuple[str, ...] | None:
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError:
        return None
    return tuple(getattr(module, "__all__", ()))


def private_imports(path: Path) -> list[str]:
    """Imports of a script that reach past the public API of bayesnsi."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    modules_bound: dict[str, str] = {}  # local name -> bayesnsi module
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _in(alias.name, "bayesnsi"):
                    if any(part.startswith("_") for part in alias.name.split(".")):
                        found.append(f"line {node.lineno}: import {alias.name} (private module)")
                    modules_bound[alias.asname or alias.name] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and _in(node.module, "bayesnsi"):
            if any(part.startswith("_") for part in node.module.split(".")):
                found.append(f"line {node.lineno}: from {node.module} (private module)")
                continue
            public = _public_names(node.module)
            for alias in node.names:
                submodule = f"{node.module}.{alias.name}"
                if alias.name not in (public or ()) and _public_names(submodule) is not None:
                    if alias.name.startswith("_"):
                        found.append(f"line {node.lineno}: from {node.module} import {alias.name} (private module)")
                    modules_bound[alias.asname or alias.name] = submodule
                elif alias.name.startswith("_") and alias.name != "__version__":
                    found.append(f"line {node.lineno}: from {node.module} import {alias.name} (private name)")
                elif public is not None and alias.name not in public:
                    found.append(f"line {node.lineno}: from {node.module} import {alias.name} (not in its __all__)")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in modules_bound:
            module_name = modules_bound[node.value.id]
            public = _public_names(module_name) or ()
            if node.attr not in public and _public_names(f"{module_name}.{node.attr}") is None:
                found.append(f"line {node.lineno}: {node.value.id}.{node.attr} (not in {module_name}.__all__)")
    return found


def test_private_import_checker(tmp_path):
    script = tmp_path / "script.py"
    script.write_text(
        "import bayesnsi.nsi as nsi\n"
        "from bayesnsi.cli._common import progress\n"
        "from bayesnsi.nsi import identify, _hankel\n"
        "from bayesnsi.options import _Options\n"
        "from bayesnsi.io import _toml\n"
        "nsi.identify\n"
        "nsi.default_band\n"
    )
    problems = private_imports(script)
    assert [p.split(":")[0] for p in problems] == ["line 2", "line 3", "line 4", "line 5", "line 7"], problems


@pytest.mark.parametrize("path", _script_paths(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_scripts_import_only_public_names(path):
    offenders = private_imports(path)
    assert not offenders, f"{path.relative_to(ROOT)} reaches past the public API:\n" + "\n".join(offenders)
