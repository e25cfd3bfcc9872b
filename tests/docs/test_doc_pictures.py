"""Every image README.md and the docs under docs/ show is one the docs' picture script knows
(cavesim/tools/reports/doc_pictures.py): drawn by it, or named with the command that draws
it. Nothing is drawn here."""

import re
from pathlib import Path

from cavesim.tools.reports.doc_pictures import IMAGES, PICTURES

ROOT = Path(__file__).parents[2]
IMAGE_LINK = re.compile(r"!\[[^\]]*\]\(([^)\s]+)")  # ![alt](path ...)


def shown_images() -> set[str]:
    """The images under docs/images the docs show, as paths from the repository root."""
    shown = set()
    for doc in (ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))):
        for link in IMAGE_LINK.findall(doc.read_text(encoding="utf-8")):
            path = (doc.parent / link).resolve().relative_to(ROOT.resolve())
            if path.parent == IMAGES:
                shown.add(path.name)
    return shown


def test_every_image_the_docs_show_is_in_the_picture_table():
    table = {picture.name for picture in PICTURES}
    shown = shown_images()
    assert shown, "the docs show no images: the link pattern no longer finds them"
    assert shown <= table, f"not in doc_pictures.PICTURES: {sorted(shown - table)}"


def test_every_picture_in_the_table_exists_and_says_what_draws_it():
    for picture in PICTURES:
        assert (ROOT / IMAGES / picture.name).is_file(), picture.name
        assert (picture.draw is None) != (not picture.command), picture.name
