"""The benchmark in the terminal: a progress bar while measuring, then the table and targets."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.report import HEADERS, table_rows, target_line

ARITHMETIC_HEADERS = (("", "particles"), ("GS/TF", "frame ms"), ("portable GS/TF", "frame ms"),
                      ("compute", "frame ms"), ("portable compute", "frame ms"),
                      ("portable", "cost"))
ENGINE_HEADERS = tuple(h for h in HEADERS if not h[0].startswith("portable"))


def progress_bar(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=console, transient=True)


def show(report: dict, sizes: list[SizeFigures], console: Console) -> None:
    """The markdown table's cells as two terminal tables (one would not fit 120 columns):
    the engine paths, then native against portable arithmetic."""
    rows = table_rows(sizes)
    for title, headers in ((f"cavesim bench - scene {report['scene']['name']}", ENGINE_HEADERS),
                           ("native against portable arithmetic", ARITHMETIC_HEADERS)):
        table = Table(title=title)
        columns = [HEADERS.index(header) for header in headers]
        for header in headers:
            table.add_column("\n".join(header), justify="right")
        for row in rows:
            table.add_row(*(row[c] for c in columns))
        console.print(table)
    for skip in report["skipped_sizes"]:
        console.print(f"not measured: {skip['particles']:,} particles ({skip['why']})",
                      markup=False, highlight=False)
    console.print("targets:")
    for target in report["targets"]:
        style = "green" if target["met"] else "bold red"
        console.print(f"  {target_line(target)}", style=style)
