"""The progress bar of a long command: what is done of how much, its rate in the task's
own unit ("58.2 frames/s"), the time spent and the time left."""

from __future__ import annotations

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.text import Text


class RateColumn(ProgressColumn):
    """A task's rate in its own unit: "58.2 frames/s"."""

    def render(self, task: Task) -> Text:
        speed = task.finished_speed or task.speed
        rate = "-" if speed is None else f"{speed:.1f}"
        return Text(f"{rate} {task.fields.get('unit', '')}/s")


def rated_progress(console: Console) -> Progress:
    """A Progress whose tasks each give `unit` (what the rate counts) and `live` (a
    note of their own, "" for none)."""
    return Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    RateColumn(), TextColumn("{task.fields[live]}"), TimeElapsedColumn(),
                    TextColumn("left"), TimeRemainingColumn(), console=console,
                    transient=False)
