"""`run_render_bench`: the typed entry of `cavesim bench --render`, from a scene to
`bench-render.json` and `bench-render.md` in the bench's own folder.

A line is printed per measurement as soon as it is taken, and both files are rewritten
after each, so that a stopped run (Ctrl-C, SIGTERM) leaves what it measured and says so.
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from pathlib import Path

import moderngl
import numpy as np
from rich.console import Console
from rich.table import Table

from cavesim.core.cave.geometry import Wall
from cavesim.core.output import write_atomically
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.bench.display import say
from cavesim.tools.bench.render_cost import (
    HEAD,
    RENDER_TARGET,
    WARMUP_DRAWS,
    DrawCost,
    measure_render,
)
from cavesim.tools.bench.report import Ended

HEADERS = ("workload", "particles", "wall px", "wall m", "draws", "p50 ms", "p90 ms",
           "draws/s", "M particles/s")
NOTES = (
    "a draw is WallRenderer.draw (scene, dust and composite passes) of one wall for one eye, "
    "then ctx.finish(): the GPU's work done; p50 and p90 of the timed draws after the "
    "warm-up draws",
    "the wall is the default CAVE's 3 m front wall, its height set by the resolution so its "
    "pixels are square; the head stands at the CAVE's centre at eye height",
    "a pool of N: N of the scene's particles spread over its field box, every one live; the "
    "scene at frame K: its state after K frames of the master's inputs",
)


def run_render_bench(scene: Scene, front: Wall, resolutions: list[tuple[int, int]],
                     sizes: list[int] | None, frame: int, draws: int, out_dir: Path,
                     console: Console, ctx: moderngl.Context | None = None
                     ) -> dict[str, object]:
    """Measure `front` reshaped to each resolution, print a line per measurement and the
    table and target, write the files; return the JSON report. Opens (and releases) its
    own context unless one is given."""
    own_context = ctx is None
    ctx = create_context() if own_context else ctx
    costs: list[DrawCost] = []
    try:
        if sizes:
            capacity_limits(ctx.info).check(max(sizes))
        gl, software = describe(ctx), ctx.extra.get("kind") == "software"

        def save(ended: str) -> tuple[dict[str, object], list[Path]]:
            report = build_report(scene, gl, software, frame, draws, costs, ended)
            return report, write_reports(report, out_dir)

        def measured(cost: DrawCost) -> None:
            costs.append(cost)
            say(console, cost_line(cost))
            save(Ended.RUNNING)

        workload = (f"pools of {', '.join(f'{n:,}' for n in sizes)}" if sizes
                    else f"{scene.name} at frame {frame}")
        say(console, f"cavesim bench --render on {gl['renderer']}: {workload}; walls "
                     f"{', '.join(f'{w}x{h}' for w, h in resolutions)}; {WARMUP_DRAWS} "
                     f"warm-up draws, then {draws} timed")
        try:
            measure_render(ctx, scene, front, resolutions, sizes, frame, draws, measured)
            ended = Ended.COMPLETE
        except KeyboardInterrupt:
            ended = Ended.INTERRUPTED
    finally:
        if own_context:
            ctx.release()
    report, paths = save(ended)
    console.print(table(report))
    say(console, f"target: {target_line(report['target'])}")
    for path in paths:
        say(console, f"wrote {path}")
    return report


def cost_line(cost: DrawCost) -> str:
    """'  brownout at frame 720   231,404  1920x1200   p50 212.40 ms  p90 ...'."""
    figures = cost.to_json()
    return (f"{cost.workload:>24} {cost.particles:>11,}  {cost.resolution[0]}x"
            f"{cost.resolution[1]:<5} p50 {cost.p50_ms:9.2f} ms  p90 {cost.p90_ms:9.2f} ms  "
            f"{figures['draws_per_s']:8.2f} draws/s  "
            f"{figures['particles_per_s'] / 1e6:8.2f} M particles/s")


def rows(report: dict) -> list[tuple[str, ...]]:
    return [(m["workload"], f"{m['particles']:,}", "x".join(map(str, m["resolution"])),
             " x ".join(f"{x:g}" for x in m["wall_m"]), str(m["draws"]), f"{m['p50_ms']:.2f}",
             f"{m['p90_ms']:.2f}", f"{m['draws_per_s']:.2f}",
             f"{m['particles_per_s'] / 1e6:.2f}") for m in report["measurements"]]


def table(report: dict) -> Table:
    result = Table(title=f"cavesim bench --render - one wall, one eye ({report['ended']})")
    for header in HEADERS:
        result.add_column(header, justify="left" if header == "workload" else "right")
    for row in rows(report):
        result.add_row(*row)
    return result


def target_line(target: dict) -> str:
    """'p50 <= 4 ms at 1920x1200 with 1,000,000 particles (GPU target): ... - not judged: a
    GPU target, and this renderer is not one'."""
    width, height = target["resolution"]
    bound = (f"p50 {target['comparison']} {target['target_ms']:g} ms per wall per eye at "
             f"{width}x{height} with {target['particles']:,} particles ({target['renderer']} "
             f"target)")
    measured = (f"not measured (it needs --sizes {target['particles']} and {width}x{height} "
                f"among the resolutions)" if target["measured_ms"] is None
                else f"measured {target['measured_ms']:.2f} ms")
    if not target["applies"]:
        verdict = f"not judged: a {target['renderer']} target, and this renderer is not one"
    elif target["met"] is None:
        verdict = "not judged"
    else:
        verdict = "met" if target["met"] else "NOT met"
    return f"{bound}: {measured} - {verdict}"


def build_report(scene: Scene, gl: dict[str, str], software: bool, frame: int, draws: int,
                 costs: list[DrawCost], ended: str) -> dict[str, object]:
    return {
        "command": "bench --render",
        "ended": ended,
        "scene": {"name": scene.name, "source": str(scene.source) if scene.source else None},
        "built_up_frame": frame,
        "gl": gl,
        "software": software,
        "cpu_count": os.cpu_count(),
        # other work on the machine slows a software renderer's draws: say how much there was
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "head": list(HEAD),
        "warmup_draws": WARMUP_DRAWS,
        "draws": draws,
        "measurements": [cost.to_json() for cost in costs],
        "target": RENDER_TARGET.evaluate(costs, software),
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def markdown(report: dict) -> str:
    gl = report["gl"]
    lines = [f"# cavesim bench --render - scene {report['scene']['name']}", "",
             f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs (load average "
             f"{' / '.join(map(str, report['load_average']))} at the end), "
             f"{report['warmup_draws']} warm-up and {report['draws']} timed draws per "
             f"measurement, {report['created']}; run {report['ended']}", "",
             "| " + " | ".join(HEADERS) + " |",
             "|---|" + "|".join("---:" for _ in HEADERS[1:]) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows(report)]
    lines += ["", "## Target", "", f"- {target_line(report['target'])}"]
    lines += ["", "## Notes", ""] + [f"- {note}" for note in report["notes"]]
    return "\n".join(lines) + "\n"


def write_reports(report: dict, out_dir: Path) -> list[Path]:
    """Replace bench-render.json and bench-render.md in `out_dir`, each whole or not at all."""
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out_dir / "bench-render.json", out_dir / "bench-render.md"
    write_atomically(json_path, json.dumps(report, indent=2) + "\n")
    write_atomically(md_path, markdown(report))
    return [json_path, md_path]
