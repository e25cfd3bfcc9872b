"""Every relative link of the README and the docs leads somewhere: its file exists, and its
#anchor is a heading of that file (GitHub's slugs), so moving a section cannot strand one."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
DOCS = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def outside_code(text: str) -> str:
    return re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)


def anchors(path: Path) -> set[str]:
    return {slug(h) for h in re.findall(r"^#+ (.*)$", outside_code(path.read_text()), re.M)}


def test_slugs_follow_github():
    assert slug("The launch script: `deploy/launch.sh`") == "the-launch-script-deploylaunchsh"
    assert slug("ETD2RK, the default integrator") == "etd2rk-the-default-integrator"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(doc):
    for target in LINK.findall(outside_code(doc.read_text())):
        if re.match(r"[a-z]+:", target):
            continue
        path, _, anchor = target.partition("#")
        dest = (doc.parent / path).resolve() if path else doc
        assert dest.exists(), f"{doc.name}: link to {target}: no such file"
        assert dest.is_relative_to(ROOT), f"{doc.name}: link to {target} leaves the project"
        if anchor and dest.suffix == ".md":
            assert anchor in anchors(dest), f"{doc.name}: link to {target}: no such heading"
