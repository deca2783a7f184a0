"""The reports of `select` and `diagnose` in a real headless browser.

Checks what a reader would notice: no console or page errors, no broken image, nothing wider
than the page (wide tables scroll inside their own container instead), and the answer before
the evidence. Uses Debian's chromium (``apt-get install chromium``) through playwright when the
python package is installed (``pip install playwright``; its own browser download is not needed),
else chromium's ``--dump-dom`` on a copy of the report that records the same facts in the DOM.
Skipped, with a message, where no chromium is found (``BAYESNSI_CHROMIUM`` names another binary).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from bayesnsi.cli import main

CHROMIUM = os.environ.get("BAYESNSI_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
WIDTH = 1400  # a desktop window; tables wider than the column scroll inside their own container
HEIGHT = 900  # the first screen

needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no chromium found (apt-get install chromium, or set BAYESNSI_CHROMIUM)"
)

# What the page shows a reader, collected in the page: broken images, elements that stick out of
# the page (not counting those inside a container that scrolls sideways), the page's own width.
_CHECKS = """() => {
  const page = document.documentElement.clientWidth;
  const scrolls = (e) => { for (let a = e.parentElement; a; a = a.parentElement) {
      const o = getComputedStyle(a).overflowX; if (o === 'auto' || o === 'scroll') return true; } return false; };
  const wide = [...document.body.querySelectorAll('*')]
      .filter(e => e.getBoundingClientRect().right > page + 1 && !scrolls(e))
      .map(e => e.tagName.toLowerCase() + (e.className ? '.' + e.className : ''));
  const broken = [...document.images].filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt);
  const headings = [...document.querySelectorAll('h2')].map(h => h.textContent);
  const alts = [...document.images].map(i => i.alt);
  const lead = document.querySelector('p.lead, p.lead-bad');
  const answerTop = lead ? lead.getBoundingClientRect().top + window.scrollY : null;
  return {page, scrollWidth: document.documentElement.scrollWidth, wide, broken, images: document.images.length,
          headings, alts, answerTop};
}"""


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """report.html of `select` on the two-DOF case and of `diagnose` on the Coulomb case (short runs)."""
    folder = tmp_path_factory.mktemp("browser")
    quick = "\n[evidence]\nn_walkers = 16\nn_steps = 400\nn_burn = 100\n"
    out = {}
    for command, case in (("select", "two-dof"), ("diagnose", "coulomb-dof2")):
        csv = folder / f"{case}.csv"
        duration = ["--duration", "6"] if command == "select" else []  # the loop needs the whole record
        assert main(["simulate", case, "--seed", "1", *duration, "--out", str(csv), "--quiet"]) == 0
        config = csv.with_suffix(".toml")
        config.write_text(config.read_text() + quick)
        extra = ["--max-steps", "1"] if command == "diagnose" else []
        assert main([command, str(config), "--out", str(folder / command), "--quiet", *extra]) == 0
        out[command] = folder / command / "report.html"
    return out


def _with_playwright(path: Path) -> dict:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        try:
            page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
            errors: list[str] = []
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(path.as_uri(), wait_until="load")
            facts = page.evaluate(_CHECKS)
            page.screenshot(path=str(path.with_suffix(".png")), full_page=True)
        finally:
            browser.close()
    return {**facts, "errors": errors}


def _with_dump_dom(path: Path) -> dict:
    """chromium --dump-dom on a copy that records errors and the checks in the DOM."""
    probe = (
        "<script>window.__errors=[];window.addEventListener('error',e=>__errors.push(String(e.message||e.type)),true);"
        "const _ce=console.error;console.error=(...a)=>{__errors.push(a.join(' '));_ce(...a)};</script>"
    )
    report = path.read_text(encoding="utf-8").replace("<head>", "<head>" + probe, 1)
    report = report.replace(
        "</body>",
        "<script>window.addEventListener('load',()=>{const f=(" + _CHECKS + ")();f.errors=__errors;"
        "document.body.setAttribute('data-checks',JSON.stringify(f));});</script></body>",
    )
    copy = path.with_name("probe.html")
    copy.write_text(report, encoding="utf-8")
    dom = subprocess.run(
        [CHROMIUM, *FLAGS, f"--window-size={WIDTH},{HEIGHT}", "--virtual-time-budget=5000", "--dump-dom",
         copy.as_uri()],
        capture_output=True, text=True, timeout=120, check=True,
    ).stdout
    marker = "data-checks=\""
    start = dom.index(marker) + len(marker)
    import html

    return json.loads(html.unescape(dom[start : dom.index('"', start)]))


def _facts(path: Path) -> dict:
    try:
        import playwright  # noqa: F401
    except ImportError:
        return _with_dump_dom(path)
    return _with_playwright(path)


@needs_chromium
@pytest.mark.parametrize("command", ["select", "diagnose"])
def test_report_reads_cleanly_in_chromium(reports, command):
    facts = _facts(reports[command])
    assert facts["errors"] == [], facts["errors"]
    assert facts["broken"] == [] and facts["images"] >= 5, facts
    assert facts["wide"] == [], f"elements wider than the {facts['page']} px page: {facts['wide'][:10]}"
    assert facts["scrollWidth"] <= facts["page"], "the page scrolls sideways"
    assert facts["headings"][0] == "Answer" and facts["headings"][-1] == "Versions", facts["headings"]
    assert facts["answerTop"] is not None and facts["answerTop"] < HEIGHT - 100, "no answer on the first screen"
    if command == "diagnose":
        assert facts["headings"][1].startswith("Closing the loop")
        assert facts["headings"][2].startswith("Before the loop")
        assert any(alt.startswith("Restoring-force view of sign(v) at DOF 2") for alt in facts["alts"]), facts["alts"]


@needs_chromium
def test_dump_dom_fallback_agrees(reports):
    """The fallback without playwright finds the same (no errors, no broken images, nothing too wide)."""
    facts = _with_dump_dom(reports["select"])
    assert facts["errors"] == [] and facts["broken"] == [] and facts["wide"] == [], facts


def test_diagnose_reports_and_saves_the_final_model(reports):
    """The loop's final model, not only the starting one: its posterior file, evidence and overlay."""
    from bayesnsi.io.posterior import read_posterior

    folder = reports["diagnose"].parent
    results = json.loads((folder / "results.json").read_text())
    final = [name for name in results["posterior_files"] if name.startswith("final: ")]
    assert final == ["final: v1*abs(v1)@1 + sign(v2)@2"], results["posterior_files"]
    tree = read_posterior(folder / results["posterior_files"][final[0]])
    assert list(tree["posterior"]["coefficient"].coords["term"].values) == ["v1*abs(v1)@1", "sign(v2)@2"]
    assert results["final_evidence"]["log_evidence"] > results["candidates"][0]["log_evidence"]
    html = reports["diagnose"].read_text()
    # the final posterior first, the final model's modes and FRF in the answer
    assert html.index("final: v1*abs(v1)@1 + sign(v2)@2 - log evidence") < html.index("declared - log evidence")
    assert "against the starting and the final model" in html
    answer = html.split("<h2")[1]
    assert "Natural frequencies and damping ratios" in answer and "FRF of the final model" in answer
