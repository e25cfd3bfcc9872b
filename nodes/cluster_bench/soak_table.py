"""How the soak shows itself: a line per memory sample while it runs, then the table of
every sample (MB per process) with the growth, and soak.json."""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console
from rich.table import Table


def _mb(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def sample_line(sample: dict) -> str:
    """'frame 10,000 (41.2 s): master 98.3 MB, front 141.0 MB, left 140.7 MB'."""
    memory = ", ".join(f"{name} {_mb(mb)} MB" for name, mb in sample["rss_mb"].items())
    return f"frame {sample['frame']:,} ({sample['seconds']:.1f} s): {memory}"


def show(report: dict, console: Console) -> None:
    processes = list(report["growth_mb"])
    table = Table(title=f"soak - {Path(report['scene']).name}, {report['walls']} walls, "
                        f"{report['frames']:,} frames")
    table.add_column("frame", justify="right")
    for name in processes:
        table.add_column(f"{name} MB", justify="right")
    for sample in report["samples"]:
        table.add_row(f"{sample['frame']:,}", *(_mb(sample["rss_mb"][n]) for n in processes))
    table.add_row("growth", *(_signed(report["growth_mb"][n]) for n in processes),
                  style="bold")
    if report["steady_growth_mb"] is not None:
        table.add_row(f"since {report['sample_every']:,}",
                      *(_signed(report["steady_growth_mb"][n]) for n in processes))
    console.print(table)
    console.print(f"{report['frames']:,} frames in {report['seconds']:.1f} s "
                  f"({report['frames_per_second']:.0f} frames/s) on {report['renderer']}; "
                  f"divergences: {report['divergences']}, stalls: {report['stalls']}",
                  markup=False, highlight=False)


def _signed(value: float | None) -> str:
    return "-" if value is None else f"{value:+.1f}"


def write_report(report: dict, out_dir: Path) -> Path:
    """Write soak.json into `out_dir`; its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "soak.json"
    path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return path
