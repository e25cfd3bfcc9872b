"""The benchmark's files: `bench.json` (compared run to run) and `bench.md` (read by people).

Both are rewritten whole after every finished size, so a run stopped at any moment leaves
the sizes it finished; `ended` says whether the run was still going, complete, interrupted,
or stopped by an error (its message). The table rows are built once here; the terminal
table (`display.py`) shows the same cells.
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path

import moderngl
import numpy as np

from cavesim.core.output import write_atomically
from cavesim.core.scene.model import Scene
from cavesim.tools.bench.figures import SizeFigures, evaluate_targets
from cavesim.tools.bench.measure import MIN_TIMED_FRAMES, BenchPlan


class Ended(StrEnum):
    """How a run ended, as `ended` in bench.json; an error's message stands in their place."""

    RUNNING = "running"  # a size's checkpoint: the run went on, or was killed
    COMPLETE = "complete"
    INTERRUPTED = "interrupted"  # Ctrl-C or SIGTERM


# Two-line column headers: stacked in the terminal, joined by a space in markdown
HEADERS = (("", "particles"), ("GS/TF", "frame ms"), ("compute", "frame ms"),
           ("compute", "speedup"), ("portable GS/TF", "frame ms"),
           ("portable compute", "frame ms"), ("portable", "cost"), ("GS/TF", "update ms"),
           ("compute", "update ms"),
           ("copy", "ms"), ("GS/TF frame", "vs copy"), ("compute frame", "vs copy"),
           ("checksum", "ms"), ("numpy", "ms"), ("GS/TF", "vs numpy"))
NOTES = (
    "seconds are medians of the timed frames after the warm-up frames; a path's frames stop "
    "once they have taken path_budget_s (at least min_frames), so `frames` per size says how "
    "many each path timed",
    "a frame is ParticleSystem.step and checksum(), waited for; the pool is preloaded full "
    "and nothing dies, so the emission finds no room and adds no particle",
    "gs_tf: geometry shader + transform feedback (two query waits a frame, then the "
    "checksum's reads); compute: in-place update, ordered compaction, append (the live "
    "count in one 4-byte read, then the checksum's reads)",
    "update is the particle pass alone: the transform-feedback pass (GS/TF), the in-place "
    "compute pass with its survivor masks (compute)",
    "copy is ctx.copy_buffer of the particle state (count x 40 bytes, read and written): the "
    "memory-bandwidth bound on this context",
    "numpy is TwinSystem in float32 on the CPU, timed up to numpy_up_to particles: above, "
    "its seconds, rate and ratio are null",
    "portable: the same frames with [simulation] arithmetic = \"portable\" (own division, "
    "square root and exp from correctly rounded +, -, *, denormals flushed: the same bits on "
    "every GPU); cost = portable compute frame / native compute frame",
    "compute_speedup = gs_tf_frame / compute_frame; *_vs_copy = path / copy; "
    "gs_tf_vs_numpy = numpy / gs_tf_frame; checksum_share = checksum / compute_frame",
)


def format_ratio(name: str, value: float) -> str:
    return f"{value:.1%}" if name == "checksum_share" else f"{value:.2f}x"


def numpy_not_timed(numpy_up_to: int) -> str:
    return f"not timed (above {numpy_up_to:,})"


def table_rows(sizes: list[SizeFigures], numpy_up_to: int) -> list[tuple[str, ...]]:
    """One row of display cells per size, in HEADERS order."""
    rows = []
    for f in sizes:
        ms = [f"{f.seconds(path) * 1e3:.2f}" for path in
              ("gs_tf_frame", "compute_frame")]
        updates = [f"{f.seconds(path) * 1e3:.2f}" for path in ("gs_tf_update", "compute_update")]
        updates.append(f"{f.copy_s * 1e3:.3f}")
        portable = [f"{f.seconds(path) * 1e3:.2f}" for path in
                    ("gs_tf_portable_frame", "compute_portable_frame")]
        numpy = ((f"{f.numpy_s * 1e3:.1f}", format_ratio("gs_tf_vs_numpy", f.gs_tf_vs_numpy))
                 if f.numpy_s is not None else (numpy_not_timed(numpy_up_to),) * 2)
        rows.append((f"{f.particles:,}", *ms, format_ratio("compute_speedup", f.compute_speedup),
                     *portable, format_ratio("compute_portable_cost", f.compute_portable_cost),
                     *updates, format_ratio("gs_tf_frame_vs_copy", f.gs_tf_frame_vs_copy),
                     format_ratio("compute_frame_vs_copy", f.compute_frame_vs_copy),
                     f"{f.checksum_s * 1e3:.2f}", *numpy))
    return rows


def target_line(target: dict) -> str:
    """'compute_speedup >= 3 at 1,000,000 particles (llvmpipe target): measured 1.50x - NOT
    met'; a target no size measured says so."""
    bound = f"{target['name']} {target['comparison']} {target['target']:g}"
    if target["measured"] is None:
        return f"{bound} ({target['renderer']} target): not measured at any size"
    measured = format_ratio(target["name"], target["measured"])
    if not target["applies"]:
        verdict = f"not judged: a {target['renderer']} target, and this renderer is not one"
    else:
        verdict = "met" if target["met"] else "NOT met"
    return (f"{bound} at {target['particles']:,} particles ({target['renderer']} target): "
            f"measured {measured} - {verdict}")


def build_report(scene: Scene, gl: dict[str, str], plan: BenchPlan, sizes: list[SizeFigures],
                 skipped: list[dict], ended: str, software: bool) -> dict[str, object]:
    """`skipped`: the default sizes this context cannot hold, each with why; `ended`: an
    `Ended` or an error's one-line message; `software`: the renderer is llvmpipe (its
    targets are judged, a GPU's are not, and the other way round)."""
    return {
        "command": "bench",
        "ended": ended,
        "scene": {"name": scene.name, "source": str(scene.source) if scene.source else None},
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "frames": plan.frames,
        "path_budget_s": plan.path_budget_s,
        "min_frames": MIN_TIMED_FRAMES,
        "numpy_up_to": plan.numpy_up_to,
        "sizes": [_size_json(figures, plan.numpy_up_to) for figures in sizes],
        "skipped_sizes": list(skipped),
        "targets": evaluate_targets(sizes, software),
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def _size_json(figures: SizeFigures, numpy_up_to: int) -> dict[str, object]:
    size = figures.to_json()
    if figures.numpy_s is None:
        size["not_timed"] = {"numpy": f"above numpy_up_to, {numpy_up_to:,} particles"}
    return size


def markdown(report: dict, sizes: list[SizeFigures]) -> str:
    gl = report["gl"]
    lines = [f"# cavesim bench - scene {report['scene']['name']}", "",
             f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs, up to "
             f"{report['frames']} timed frames per path (fewer past {report['path_budget_s']:g}"
             f" s, at least {report['min_frames']}), {report['created']}; run "
             f"{report['ended']}", "",
             "| " + " | ".join(" ".join(h).strip() for h in HEADERS) + " |",
             "|" + "|".join("---:" for _ in HEADERS) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(sizes, report["numpy_up_to"])]
    lines += [f"\nNot measured: {skip['particles']:,} particles ({skip['why']})."
              for skip in report["skipped_sizes"]]
    lines += ["", "## Targets", ""]
    lines += [f"- {target_line(target)}" for target in report["targets"]]
    lines += ["", "## Notes", ""] + [f"- {note}" for note in report["notes"]]
    return "\n".join(lines) + "\n"


def write_reports(report: dict, sizes: list[SizeFigures], out_dir: Path) -> list[Path]:
    """Replace bench.json and bench.md in `out_dir` (created if missing), each whole or not
    at all; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out_dir / "bench.json", out_dir / "bench.md"
    write_atomically(json_path, json.dumps(report, indent=2) + "\n")
    write_atomically(md_path, markdown(report, sizes))
    return [json_path, md_path]
