"""The accuracy run in the terminal: a progress bar while measuring, then one table per case
with the markdown table's main columns (the full table is in accuracy.md)."""

from __future__ import annotations

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.tools.numerics.report import HEADERS, table_rows
from cavesim.tools.numerics.results import Summary

TERMINAL_HEADERS = ("integrator", "order", "expected", "observed (f64)", "verdict",
                    "GPU RMS (m)", "f64 RMS (m)", "float32 floor (m)", "GPU ms/step",
                    "portable cost")  # 120 columns; filtering and portable errors: accuracy.md
VERDICT_STYLES = {"ok": "green", "exact": "green", "OFF": "bold red", "NOT exact": "bold red"}


def progress_bar(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=console, transient=True)


def show(report: dict, summaries: list[Summary], console: Console) -> None:
    columns = [HEADERS.index(h) for h in TERMINAL_HEADERS]
    for case in report["cases"]:
        table = Table(title=f"{case['name']}: reference {case['reference']}; errors at dt = "
                            f"{report['report_dt']} s", box=box.SIMPLE_HEAD)
        table.add_column(TERMINAL_HEADERS[0], no_wrap=True)
        for header in TERMINAL_HEADERS[1:]:
            table.add_column(header, justify="right")
        for row in table_rows([s for s in summaries if s.case == case["name"]]):
            table.add_row(*(row[c] for c in columns),
                          style=VERDICT_STYLES.get(row[HEADERS.index("verdict")]))
        console.print(table)
