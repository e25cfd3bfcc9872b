"""The benchmark's files: `bench.json` (compared run to run) and `bench.md` (read by people).

The table rows are built once here; the terminal table (`display.py`) shows the same cells.
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from pathlib import Path

import moderngl
import numpy as np

from cavesim.core.scene.model import Scene
from cavesim.tools.bench.figures import SizeFigures, evaluate_targets

# Two-line column headers: stacked in the terminal, joined by a space in markdown
HEADERS = (("", "particles"), ("GS/TF", "frame ms"), ("compute", "frame ms"),
           ("compute", "speedup"), ("portable GS/TF", "frame ms"),
           ("portable compute", "frame ms"), ("portable", "cost"), ("GS/TF", "update ms"),
           ("compute", "update ms"),
           ("copy", "ms"), ("GS/TF frame", "vs copy"), ("compute frame", "vs copy"),
           ("checksum", "ms"), ("numpy", "ms"), ("GS/TF", "vs numpy"))
NOTES = (
    "seconds are medians of the timed frames after the warm-up frames",
    "a frame is ParticleSystem.step and checksum(), waited for; the pool is preloaded full "
    "and nothing dies, so the emission finds no room and adds no particle",
    "gs_tf: geometry shader + transform feedback (two query waits a frame, then the "
    "checksum's reads); compute: in-place update, ordered compaction, append (the live "
    "count in one 4-byte read, then the checksum's reads)",
    "update is the particle pass alone: the transform-feedback pass (GS/TF), the in-place "
    "compute pass with its survivor masks (compute)",
    "copy is ctx.copy_buffer of the particle state (count x 40 bytes, read and written): the "
    "memory-bandwidth bound on this context",
    "numpy is TwinSystem in float32 on the CPU",
    "portable: the same frames with [simulation] arithmetic = \"portable\" (own division, "
    "square root and exp from correctly rounded +, -, *, denormals flushed: the same bits on "
    "every GPU); cost = portable compute frame / native compute frame",
    "compute_speedup = gs_tf_frame / compute_frame; *_vs_copy = path / copy; "
    "gs_tf_vs_numpy = numpy / gs_tf_frame; checksum_share = checksum / compute_frame",
)


def format_ratio(name: str, value: float) -> str:
    return f"{value:.1%}" if name == "checksum_share" else f"{value:.2f}x"


def table_rows(sizes: list[SizeFigures]) -> list[tuple[str, ...]]:
    """One row of display cells per size, in HEADERS order."""
    rows = []
    for f in sizes:
        ms = [f"{f.seconds(path) * 1e3:.2f}" for path in
              ("gs_tf_frame", "compute_frame")]
        updates = [f"{f.seconds(path) * 1e3:.2f}" for path in ("gs_tf_update", "compute_update")]
        updates.append(f"{f.copy_s * 1e3:.3f}")
        portable = [f"{f.seconds(path) * 1e3:.2f}" for path in
                    ("gs_tf_portable_frame", "compute_portable_frame")]
        rows.append((f"{f.particles:,}", *ms, format_ratio("compute_speedup", f.compute_speedup),
                     *portable, format_ratio("compute_portable_cost", f.compute_portable_cost),
                     *updates, format_ratio("gs_tf_frame_vs_copy", f.gs_tf_frame_vs_copy),
                     format_ratio("compute_frame_vs_copy", f.compute_frame_vs_copy),
                     f"{f.checksum_s * 1e3:.2f}", f"{f.numpy_s * 1e3:.1f}",
                     format_ratio("gs_tf_vs_numpy", f.gs_tf_vs_numpy)))
    return rows


def target_line(target: dict) -> str:
    """'compute_speedup >= 3 at 1,000,000 particles (llvmpipe target): measured 1.50x - NOT
    met'."""
    measured = format_ratio(target["name"], target["measured"])
    verdict = "met" if target["met"] else "NOT met"
    return (f"{target['name']} {target['comparison']} {target['target']:g} at "
            f"{target['particles']:,} particles ({target['renderer']} target): measured "
            f"{measured} - {verdict}")


def build_report(scene: Scene, gl: dict[str, str], frames: int, sizes: list[SizeFigures],
                 skipped: list[dict] = ()) -> dict[str, object]:
    """`skipped`: the default sizes this context cannot hold, each with why."""
    return {
        "command": "bench",
        "scene": {"name": scene.name, "source": str(scene.source) if scene.source else None},
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "frames": frames,
        "sizes": [figures.to_json() for figures in sizes],
        "skipped_sizes": list(skipped),
        "targets": evaluate_targets(sizes),
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def markdown(report: dict, sizes: list[SizeFigures]) -> str:
    gl = report["gl"]
    lines = [f"# cavesim bench - scene {report['scene']['name']}", "",
             f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs, "
             f"{report['frames']} timed frames, {report['created']}", "",
             "| " + " | ".join(" ".join(h).strip() for h in HEADERS) + " |",
             "|" + "|".join("---:" for _ in HEADERS) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(sizes)]
    lines += [f"\nNot measured: {skip['particles']:,} particles ({skip['why']})."
              for skip in report["skipped_sizes"]]
    lines += ["", "## Targets", ""]
    lines += [f"- {target_line(target)}" for target in report["targets"]]
    lines += ["", "## Notes", ""] + [f"- {note}" for note in report["notes"]]
    return "\n".join(lines) + "\n"


def write_reports(report: dict, sizes: list[SizeFigures], out_dir: Path) -> list[Path]:
    """Write bench.json and bench.md into `out_dir` (created if missing); return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out_dir / "bench.json", out_dir / "bench.md"
    json_path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    md_path.write_text(markdown(report, sizes), encoding="utf-8")
    return [json_path, md_path]
