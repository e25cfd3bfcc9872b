"""`run_bench`: the typed entry of `cavesim bench`, from a scene to the written reports."""

from __future__ import annotations

from pathlib import Path

import moderngl
from rich.console import Console

from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.capacity import CapacityLimits, capacity_limits
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.bench.display import progress_bar, show
from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.measure import measure_size, ticks_per_size
from cavesim.tools.bench.report import build_report, write_reports

DEFAULT_SIZES = (1_000_000, 10_000_000)  # and the largest capacity the context allows


def run_bench(scene: Scene, sizes: list[int] | None, frames: int, out_dir: Path,
              console: Console, ctx: moderngl.Context | None = None) -> dict[str, object]:
    """Measure each size, print the table and targets, write bench.json and bench.md.

    Without `sizes`: 1M, 10M and the largest capacity of the context, leaving out (and
    naming) what it cannot hold. Opens (and releases) its own GL context unless one is
    given; a size given that the context cannot hold is a CapacityError before anything is
    measured. Returns the JSON report.
    """
    own_context = ctx is None
    ctx = create_context() if own_context else ctx
    try:
        limits = capacity_limits(ctx.info)
        sizes, skipped = (sizes, []) if sizes else default_sizes(limits)
        limits.check(max(sizes))
        gl = describe(ctx)
        measured = _measure_all(ctx, scene, sizes, frames, console)
    finally:
        if own_context:
            ctx.release()
    report = build_report(scene, gl, frames, measured, skipped)
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


def default_sizes(limits: CapacityLimits) -> tuple[list[int], list[dict]]:
    """DEFAULT_SIZES that fit the context and its largest capacity; those left out, with why."""
    largest, bound = limits.max_capacity, limits.binding
    sizes = sorted({n for n in DEFAULT_SIZES if n <= largest} | {largest})
    skipped = [{"particles": n, "why": f"the largest capacity of {limits.driver} is "
                                      f"{largest:,} ({bound.name} = {bound.value} {bound.unit})"}
               for n in DEFAULT_SIZES if n > largest]
    return sizes, skipped
