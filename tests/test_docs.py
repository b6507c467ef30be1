"""User-facing text (docstrings, docs, READMEs) points only at what a user has: the project's own docs."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _user_facing() -> list[Path]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "assets").rglob("README.md"))]
    return files + sorted((ROOT / "box2d_driving").rglob("*.py")) + sorted((ROOT / "training").rglob("*.py"))


def test_no_text_cites_the_internal_design_spec():
    # users get the package, not the design notes it was built from; "SPEC 6.4" means nothing to them
    cited = [f"{p.relative_to(ROOT)}:{n}" for p in _user_facing()
             for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if re.search(r"\bSPEC\b", line)]
    assert not cited, f"cites SPEC: {cited}"


def test_every_docs_page_named_in_code_or_docs_exists():
    named = set()
    for p in _user_facing():
        text = p.read_text(encoding="utf-8")
        named |= {m for m in re.findall(r"\bdocs/([\w-]+\.md)", text)}
        if p.parent.name == "docs":  # relative links between the docs pages
            named |= {m for m in re.findall(r"\]\(([\w-]+\.md)(?:#[\w-]*)?\)", text)}
    missing = sorted(n for n in named if not (ROOT / "docs" / n).exists())
    assert named and not missing, f"named but absent under docs/: {missing}"


def test_the_readmes_links_into_the_docs_land_on_a_heading():
    """The docs site checks its own anchors (strict build); the README's links into docs/ pages are
    checked here, by the heading anchors GitHub makes (lower case, punctuation dropped)."""
    from training.results.markdown import anchor

    links = re.findall(r"\]\((docs/[\w/-]+\.md)#([\w-]+)\)", (ROOT / "README.md").read_text(encoding="utf-8"))
    assert links
    broken = []
    for page, target in links:
        headings = re.findall(r"^#+ (.+)$", (ROOT / page).read_text(encoding="utf-8"), flags=re.M)
        if target not in {anchor(h.strip()) for h in headings}:
            broken.append(f"{page}#{target}")
    assert not broken, f"README links to no heading: {broken}"


def test_the_docs_site_builds_in_strict_mode(tmp_path):
    """Warnings fail the build: a broken internal link or anchor, a page left out of the
    navigation, an API reference that does not resolve."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    page = (tmp_path / "site" / "scenarios" / "intersection" / "index.html").read_text(encoding="utf-8")
    # the settings table is generated from the config dataclass: its fields and their meanings
    assert "<code>lidar_noise</code>" in page and "share of rays dropped" in page
    assert (tmp_path / "site" / "reference" / "envs" / "index.html").exists()


def test_the_own_scenario_tutorial_runs_as_written():
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "tutorials" / "own-scenario.md").read_text(), re.S)
    assert len(blocks) == 2
    namespace: dict = {}
    for block in blocks:  # the scenario, then PettingZoo's API test on it
        exec(compile(block, "own-scenario.md", "exec"), namespace)
