"""`run_bench`: the typed entry of `cavesim bench`, from a scene to the written reports."""

from __future__ import annotations

from pathlib import Path

import moderngl
from rich.console import Console

from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.bench.display import progress_bar, show
from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.measure import measure_size, ticks_per_size
from cavesim.tools.bench.report import build_report, write_reports


def run_bench(scene: Scene, sizes: list[int], frames: int, out_dir: Path, console: Console,
              ctx: moderngl.Context | None = None) -> dict[str, object]:
    """Measure each size, print the table and targets, write bench.json and bench.md.

    Opens (and releases) its own GL context unless one is given; a size the context cannot
    hold is a CapacityError before anything is measured. Returns the JSON report.
    """
    own_context = ctx is None
    ctx = create_context() if own_context else ctx
    try:
        capacity_limits(ctx.info).check(max(sizes))
        gl = describe(ctx)
        measured = _measure_all(ctx, scene, sizes, frames, console)
    finally:
        if own_context:
            ctx.release()
    report = build_report(scene, gl, frames, measured)
    show(report, measured, console)
    for path in write_reports(report, measured, out_dir):
        console.print(f"wrote {path}", markup=False, highlight=False, soft_wrap=True)
    return report


def _measure_all(ctx: moderngl.Context, scene: Scene, sizes: list[int], frames: int,
                 console: Console) -> list[SizeFigures]:
    measured = []
    with progress_bar(console) as progress:
        task = progress.add_task("bench", total=len(sizes) * ticks_per_size(frames))
        for count in sizes:
            def tick(path: str, count: int = count) -> None:
                progress.update(task, advance=1, description=f"{count:,} particles: {path}")
            measured.append(measure_size(ctx, scene, count, frames, tick))
    return measured
