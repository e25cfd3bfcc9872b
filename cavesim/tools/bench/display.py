"""The benchmark in the terminal: a progress bar while measuring, then the table and targets."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.report import HEADERS, table_rows, target_line


def progress_bar(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=console, transient=True)


def show(report: dict, sizes: list[SizeFigures], console: Console) -> None:
    table = Table(title=f"cavesim bench - scene {report['scene']['name']}")
    for header in HEADERS:
        table.add_column("\n".join(header), justify="right")
    for row in table_rows(sizes):
        table.add_row(*row)
    console.print(table)
    for skip in report["skipped_sizes"]:
        console.print(f"not measured: {skip['particles']:,} particles ({skip['why']})",
                      markup=False, highlight=False)
    console.print("targets:")
    for target in report["targets"]:
        style = "green" if target["met"] else "bold red"
        console.print(f"  {target_line(target)}", style=style)
