"""The user documentation: README.md is a short tour, every relative link resolves, and
docs/config.md lists every key each config section accepts."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from bayesnsi import EvidenceOptions, LoopOptions, NSIOptions
from bayesnsi.io import DataSpec, IntegrationSpec, ValidationSegment

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "workflows" / "README.md",
         ROOT / "notebooks" / "README.md"]
README_MAX_LINES = 300


def _prose(text: str) -> str:
    """The text outside fenced code blocks and inline code spans (where `](...)` is mathematics)."""
    return re.sub(r"`[^`\n]*`", "", re.sub(r"```.*?```", "", text, flags=re.S))


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces as dashes."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", "")).replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return {_anchor(m.group(1)) for m in re.finditer(r"^#+ (.*)$", text, re.M)}


def test_anchor_follows_github():
    assert _anchor("The loop's final model") == "the-loops-final-model"
    assert _anchor("Resuming, parallel runs and large sweeps") == "resuming-parallel-runs-and-large-sweeps"
    assert _anchor("[diagnose]") == "diagnose"


def test_readme_is_a_short_tour_linking_the_docs_pages():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= README_MAX_LINES
    for step in ("make test", "make demo"):  # the two set-up commands, and the one CI runs
        assert step in text
    assert "make test" in (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    linked = {Path(m) for m in re.findall(r"\]\((docs/[\w.-]+\.md)(?:#[\w-]*)?\)", text)}
    pages = {p.relative_to(ROOT) for p in (ROOT / "docs").glob("*.md")}
    assert pages - linked == set(), "docs pages the README does not link"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page):
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", _prose(page.read_text(encoding="utf-8"))):
        if re.match(r"[a-z]+:", target) or not target.isascii():
            continue
        path, _, fragment = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(target)
        elif fragment and dest.suffix == ".md" and fragment not in _anchors(dest):
            broken.append(target)
    assert not broken, broken


def _config_sections() -> dict[str, str]:
    """docs/config.md split at its `## ` headings (each section with its sub-sections)."""
    text = (ROOT / "docs" / "config.md").read_text(encoding="utf-8")
    parts = re.split(r"^## (.*)$", text, flags=re.M)
    return {parts[i].strip(): parts[i + 1] for i in range(1, len(parts), 2)}


def _documented_keys(section: str) -> set[str]:
    """The keys named in the first cell of the section's table rows."""
    keys: set[str] = set()
    for line in section.splitlines():
        if line.startswith("| `"):
            keys |= set(re.findall(r"`([\w]+)`", line.split("|")[1]))
    return keys


@pytest.mark.parametrize("heading, classes", [
    ("[data]", (DataSpec, IntegrationSpec)),
    ("[nsi]", (NSIOptions,)),
    ("[evidence]", (EvidenceOptions,)),
    ("[diagnose]", (LoopOptions,)),
    ("[[validation]]", (ValidationSegment,)),
])
def test_config_reference_lists_exactly_the_keys_read(heading, classes):
    """Each section's tables name every key the loader reads, and no other."""
    documented = _documented_keys(_config_sections()[heading])
    keys = {f.name for cls in classes for f in dataclasses.fields(cls)}
    assert (sorted(keys - documented), sorted(documented - keys)) == ([], [])
