"""User-facing text (docstrings, docs, READMEs) points only at what a user has: the project's own docs."""

import re
from pathlib import Path

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
