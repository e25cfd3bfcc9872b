"""`run_bench`: the typed entry of `cavesim bench`, from a scene to the written reports.

Each path is printed as soon as it is measured, and bench.json and bench.md are rewritten
after each size, so that a long run shows how far it got and a stopped one (Ctrl-C,
SIGTERM, an error) leaves the sizes it finished, saying how it ended.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

import moderngl
from rich.console import Console

from cavesim.core.errors import OutputError
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.capacity import CapacityLimits, capacity_limits
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.bench.display import path_line, plan_line, progress_bar, say, show
from cavesim.tools.bench.figures import PATHS, SizeFigures
from cavesim.tools.bench.measure import BenchPlan, Timing, measure_size
from cavesim.tools.bench.report import Ended, build_report, write_reports

DEFAULT_SIZES = (1_000_000, 10_000_000)  # and the largest capacity the context allows
QUICK_SIZES = (100_000, 1_000_000)  # `--quick`: each capped at the largest capacity


def run_bench(scene: Scene, sizes: list[int] | None, plan: BenchPlan, out_dir: Path,
              console: Console, ctx: moderngl.Context | None = None,
              quick: bool = False) -> dict[str, object]:
    """Measure each size, print the table and targets, write bench.json and bench.md.

    Without `sizes`: 1M, 10M and the largest capacity of the context, leaving out (and
    naming) what it cannot hold; with `quick`, QUICK_SIZES instead. Opens (and releases) its
    own GL context unless one is given; a size given that the context cannot hold is a
    CapacityError before anything is measured. Ctrl-C or SIGTERM while measuring ends the
    run with the finished sizes, `ended` "interrupted"; an error writes them with its
    message before it goes on. Returns the JSON report.
    """
    own_context = ctx is None
    ctx = create_context() if own_context else ctx
    try:
        limits = capacity_limits(ctx.info)
        sizes, skipped = (sizes, []) if sizes else default_sizes(limits, quick)
        limits.check(max(sizes))
        gl = describe(ctx)
        measured: list[SizeFigures] = []

        def save(ended: str) -> tuple[dict[str, object], list[Path]]:
            report = build_report(scene, gl, plan, measured, skipped, ended,
                                  ctx.extra.get("kind") == "software")
            return report, write_reports(report, measured, out_dir)

        say(console, plan_line(gl["renderer"], sizes, plan))
        ended = _measure_all(ctx, scene, sizes, plan, console, measured, save)
    finally:
        if own_context:
            ctx.release()
    report, paths = save(ended)
    if measured:
        show(report, measured, console)
    for path in paths:
        say(console, f"wrote {path}")
    return report


def _measure_all(ctx: moderngl.Context, scene: Scene, sizes: list[int], plan: BenchPlan,
                 console: Console, measured: list[SizeFigures],
                 save: Callable[[str], object]) -> Ended:
    """Measure into `measured`, saving after each size; how the measuring ended."""
    started, total, done = time.monotonic(), len(sizes) * len(PATHS), itertools.count(1)
    try:
        with progress_bar(console) as progress:
            task = progress.add_task("bench", total=total)
            for count in sizes:
                progress.update(task, description=f"{count:,} particles")

                def show_path(path: str, timing: Timing | None, count: int = count) -> None:
                    progress.advance(task)
                    say(console, path_line(count, path, timing, plan, next(done), total,
                                           time.monotonic() - started))

                measured.append(measure_size(ctx, scene, count, plan, show_path))
                save(Ended.RUNNING)
    except KeyboardInterrupt:
        return Ended.INTERRUPTED
    except Exception as e:
        with suppress(OutputError):  # the run's own error is the one to tell
            save(" ".join(str(e).split()) or type(e).__name__)
        raise
    return Ended.COMPLETE


def default_sizes(limits: CapacityLimits, quick: bool = False) -> tuple[list[int], list[dict]]:
    """DEFAULT_SIZES that fit the context and its largest capacity, and those left out, with
    why; with `quick`, QUICK_SIZES each capped at the largest capacity, none left out."""
    largest, bound = limits.max_capacity, limits.binding
    if quick:
        return sorted({min(n, largest) for n in QUICK_SIZES}), []
    sizes = sorted({n for n in DEFAULT_SIZES if n <= largest} | {largest})
    skipped = [{"particles": n, "why": f"the largest capacity of {limits.driver} is "
                                      f"{largest:,} ({bound.name} = {bound.value} {bound.unit})"}
               for n in DEFAULT_SIZES if n > largest]
    return sizes, skipped
