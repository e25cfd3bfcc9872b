"""The benchmark in the terminal: a line per path as soon as it is measured (plain text, so
that a log or a pipe shows it too), a progress bar while measuring where the output is a
terminal, then the table and targets."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.measure import MIN_TIMED_FRAMES, WARMUP_FRAMES, BenchPlan, Timing
from cavesim.tools.bench.report import HEADERS, numpy_not_timed, table_rows, target_line

ARITHMETIC_HEADERS = (("", "particles"), ("GS/TF", "frame ms"), ("portable GS/TF", "frame ms"),
                      ("compute", "frame ms"), ("portable compute", "frame ms"),
                      ("portable", "cost"))
ENGINE_HEADERS = tuple(h for h in HEADERS if not h[0].startswith("portable"))
TARGET_STYLES = {True: "green", False: "bold red", None: "yellow"}  # met, not met, unmeasured


def progress_bar(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), console=console, transient=True)


def say(console: Console, line: str) -> None:
    """One plain line, as it is, at once: no markup, highlighting or wrapping."""
    console.print(line, markup=False, highlight=False, soft_wrap=True)


def plan_line(renderer: str, sizes: list[int], plan: BenchPlan) -> str:
    """What the run is about to measure, and how long each path may take."""
    return (f"cavesim bench on {renderer}: {', '.join(f'{n:,}' for n in sizes)} particles; "
            f"per path {WARMUP_FRAMES} warm-up frames, then up to {plan.frames} timed (fewer "
            f"past {plan.path_budget_s:g} s, at least {MIN_TIMED_FRAMES}); numpy twin up to "
            f"{plan.numpy_up_to:,} particles")


def path_line(count: int, path: str, timing: Timing | None, plan: BenchPlan, done: int,
              total: int, elapsed_s: float) -> str:
    """'  1,000,000  gs_tf_frame  113.16 ms  8.84 M particles/s  3 frames  [1/18, 4.2 s]'."""
    if timing is None:
        measured = numpy_not_timed(plan.numpy_up_to)
    else:
        measured = (f"{timing.seconds * 1e3:10.2f} ms  {count / timing.seconds / 1e6:10.2f} M "
                    f"particles/s  {timing.frames:2d} frames")
    return f"{count:>12,}  {path:<22} {measured}  [{done}/{total}, {elapsed_s:.1f} s]"


def show(report: dict, sizes: list[SizeFigures], console: Console) -> None:
    """The markdown table's cells as two terminal tables (one would not fit 120 columns):
    the engine paths, then native against portable arithmetic."""
    rows = table_rows(sizes, report["numpy_up_to"])
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
        say(console, f"not measured: {skip['particles']:,} particles ({skip['why']})")
    console.print("targets:")
    for target in report["targets"]:
        console.print(f"  {target_line(target)}", style=TARGET_STYLES[target["met"]])
