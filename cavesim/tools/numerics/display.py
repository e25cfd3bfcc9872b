"""The accuracy run in the terminal: a progress bar while measuring, then one table per case
with the markdown table's main columns and what the reference check says (the full tables
are in accuracy.md)."""

from __future__ import annotations

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.tools.numerics.report import HEADERS, reference_sentence, table_rows
from cavesim.tools.numerics.results import Summary
from cavesim.tools.numerics.tolerance_sweep import ReferenceAccuracy, SweepRow

TERMINAL_HEADERS = ("integrator", "expected", "observed (f64)", "verdict", "evals per step",
                    "GPU RMS (m)", "GPU vel RMS (m/s)", "float32 floor (m)", "GPU ms/step",
                    "portable cost")  # 120 columns; order, f64, cloud, portable errors: .md
VERDICT_STYLES = {"ok": "green", "exact": "green", "forgets": "green", "OFF": "bold red",
                  "NOT exact": "bold red", "KEEPS": "bold red"}


def progress_bar(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=console, transient=True)


def show(report: dict, summaries: list[Summary], sweep: list[SweepRow],
         accuracies: list[ReferenceAccuracy], console: Console) -> None:
    columns = [HEADERS.index(h) for h in TERMINAL_HEADERS]
    for case in report["cases"]:
        table = Table(title=f"{case['name']}: reference {case['reference']}; errors at dt = "
                            f"{report['report_dt']} s", box=box.SIMPLE_HEAD,
                      pad_edge=False)
        table.add_column(TERMINAL_HEADERS[0], no_wrap=True)
        for header in TERMINAL_HEADERS[1:]:
            table.add_column(header, justify="right")
        for row in table_rows([s for s in summaries if s.case == case["name"]]):
            table.add_row(*(row[c] for c in columns),
                          style=VERDICT_STYLES.get(row[HEADERS.index("verdict")]))
        console.print(table)
        accuracy = next((a for a in accuracies if a.case == case["name"]), None)
        console.print(reference_sentence(accuracy,
                                         [r for r in sweep if r.case == case["name"]]),
                      markup=False, highlight=False)
