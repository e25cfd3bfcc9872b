"""`cavesim run`: the master and one node per wall on this machine, with a progress bar.

Each wall computes on the EGL device its plan gives it (`nodes.gpus`); the summary names
the GPU every wall reported. report.json is written once, after the pictures and plots.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cavesim.wire.network import read_key
from nodes.cluster import ClusterPlan, run_cluster
from nodes.master import MasterConfig


@dataclass(frozen=True)
class RunPlan:
    walls: tuple[str, ...]
    scene: Path
    frames: int
    out: Path
    session: str = "run"
    key_file: Path | None = None
    cave: Path | None = None  # with render_every > 0: walls are drawn, composites assembled
    render_every: int = 0
    stereo: bool = False
    gpus: Mapping[str, int] = field(default_factory=dict)  # wall -> EGL device (else default)

    @property
    def draws(self) -> bool:
        return self.cave is not None and self.render_every > 0

    def node_args(self, wall: str) -> tuple[str, ...]:
        """The flags of `wall`'s node beyond the cluster's own: drawing, its GPU."""
        gpu = ("--gpu", str(self.gpus[wall])) if wall in self.gpus else ()
        if not self.draws:
            return gpu
        return ("--cave", str(self.cave), "--render-every", str(self.render_every),
                "--images", str(self.out / "walls"), *(("--stereo",) if self.stereo else ()),
                *gpu)

    def cluster(self) -> ClusterPlan:
        master = MasterConfig(self.walls, self.scene, self.frames, self.session,
                              key=read_key(self.key_file), frame_log=self.out / "frames.log")
        return ClusterPlan(master, self.out, self.key_file,
                           {wall: self.node_args(wall) for wall in self.walls})


def run_walls(plan: RunPlan, console: Console) -> dict:
    """Run the cluster to the end (or Ctrl-C); write and return report.json's content."""
    plan.out.mkdir(parents=True, exist_ok=True)
    columns = (TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("{task.fields[live]} live"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=False) as progress:
        task = progress.add_task(f"{len(plan.walls)} walls", total=plan.frames, live=0)
        record = run_cluster(plan.cluster(), lambda k, live: progress.update(
            task, completed=k, live=live))
    if record.interrupted:
        console.print("[yellow]interrupted: the cluster was stopped")
    report = record.summary()
    if plan.draws:
        report["images"] = assemble_images(plan, console)
    report["plots"] = [str(p) for p in write_plots(report, plan.out, console)]
    report_path = plan.out / "report.json"
    report_path.write_text(json.dumps(report, indent=2) + "\n")
    console.print(summary_table(report))
    console.print(gpu_table(report))
    if report.get("flight"):
        console.print(demo_table(report))
    console.print(f"wrote {report_path}, {plan.out / 'frames.log'}, logs in {plan.out / 'logs'}")
    return report


def assemble_images(plan: RunPlan, console: Console) -> dict:
    """Unfolded-CAVE composites of every saved frame, and an animation of the run."""
    from cavesim.cave.geometry import load_cave
    from cavesim.render.animation import write_animation
    from cavesim.render.composite import compose_run

    composites = compose_run(load_cave(plan.cave), plan.out / "walls",
                             plan.out / "composites")
    images = {"walls": str(plan.out / "walls"), "composites": len(composites)}
    if composites:
        images["animation"] = str(write_animation(composites, plan.out / "run.gif"))
        images["last_composite"] = str(composites[-1])
        console.print(f"wrote {len(composites)} composites and {images['animation']}")
    return images


def write_plots(report: dict, out: Path, console: Console) -> list[Path]:
    """The brownout demo's plots of a helicopter run (none for other scenes)."""
    if not report.get("flight"):
        return []
    from nodes.demo_report import write_demo_plots  # matplotlib: only when there is a plot

    paths = write_demo_plots(report, out)
    console.print(f"wrote {len(paths)} plots in {out / 'plots'}")
    return paths


def summary_table(report: dict) -> Table:
    rows = [
        ("frames", report["frames"]),
        ("walls", ", ".join(report["nodes"])),
        ("frames per second", report["frames_per_second"]),
        ("barrier p50 / p99 ms", f"{report['barrier_ms']['p50']} / {report['barrier_ms']['p99']}"),
        ("live particles (last / max)",
         f"{report['live_particles']['last']:,} / {report['live_particles']['max']:,}"),
        ("divergences", len(report["divergences"])),
        ("resyncs", len(report["resyncs"])),
        ("stalls", len(report["stalls"])),
        ("rejected messages", sum(report["rejected_messages"]["master"].values())
         + sum(report["rejected_messages"]["nodes"].values())),
    ]
    return _table("cavesim run", rows)


def gpu_table(report: dict) -> Table:
    """What each wall computed on, as its node told the master."""
    table = Table(title="GPUs")
    for column in ("wall", "EGL device", "renderer", "OpenGL version (driver)"):
        table.add_column(column)
    for wall in report["nodes"]:
        gpu = report["gpus"].get(wall)
        if gpu is None:
            table.add_row(wall, "?", "did not answer the info query", "")
        else:
            table.add_row(wall, f"{gpu['device']} ({gpu['kind']})", gpu["renderer"],
                          gpu["version"])
    return table


def demo_table(report: dict) -> Table:
    """The helicopter's figures: peaks of the dust, the altitude they came at."""
    from nodes.demo_report import demo_summary

    return _table("brownout demo", demo_summary(report))


def _table(title: str, rows) -> Table:
    table = Table(title=title)
    table.add_column("figure")
    table.add_column("value", justify="right")
    for name, value in rows:
        table.add_row(name, str(value))
    return table
