"""The rendering page's table of drawing techniques says what the techniques' table in
cavesim/tools/reports/technique_pictures.py says: the sheet it shows is drawn from that."""

from pathlib import Path

from cavesim.tools.reports.technique_pictures import TECHNIQUES

PAGE = Path(__file__).parents[2] / "docs" / "rendering.md"


def table_rows() -> dict[str, list[str]]:
    """The page's technique rows: name -> the other cells."""
    rows = {}
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) == 4 and cells[0] != "technique" \
                and not cells[0].startswith("---"):
            rows[cells[0]] = cells[1:]
    return rows


def test_the_page_lists_every_technique_as_the_table_has_it():
    rows = table_rows()
    assert list(rows) == [t.name for t in TECHNIQUES]
    for technique in TECHNIQUES:
        adds, left_out_by, frame = rows[technique.name]
        assert adds == technique.adds, technique.name
        assert int(frame) == technique.frame, technique.name
        assert all(f"`{key} =" in left_out_by for key in technique.without), technique.name
