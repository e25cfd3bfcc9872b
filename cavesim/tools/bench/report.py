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
from cavesim.tools.bench.figures import PATHS, SizeFigures, evaluate_targets

PATH_LABELS = {"gs_tf": "GS/TF", "compute": "compute", "numpy": "numpy", "checksum": "checksum"}
# Two-line column headers: stacked in the terminal, joined by a space in markdown
HEADERS = (("", "particles"),
           *((PATH_LABELS[p], unit) for p in PATHS[:3] for unit in ("ms", "Mp/s")),
           ("checksum", "ms"), ("GS/TF", "vs numpy"), ("GS/TF", "vs compute"),
           ("checksum", "share"))
NOTES = (
    "seconds are medians of the timed frames after the warm-up frames",
    "gs_tf is a whole ParticleSystem.step: the particle pass and the emitter pass; the pool "
    "is preloaded full and nothing dies, so the emitter pass finds no room and draws no new "
    "particle",
    "compute is the particle pass's arithmetic as an in-place compute shader on its own copy "
    "of the particles (no emission, no kill): the bound the GS/TF step is compared with",
    "numpy is TwinSystem in float32 on the CPU",
    "gs_tf_vs_numpy = numpy / gs_tf (speedup), gs_tf_vs_compute = gs_tf / compute (slowdown), "
    "checksum_share = checksum / gs_tf",
)


def format_ratio(name: str, value: float) -> str:
    return f"{value:.1%}" if name == "checksum_share" else f"{value:.2f}x"


def table_rows(sizes: list[SizeFigures]) -> list[tuple[str, ...]]:
    """One row of display cells per size, in HEADERS order."""
    rows = []
    for f in sizes:
        timings = [cell for path in PATHS[:3] for cell in (
            f"{f.seconds(path) * 1e3:.2f}", f"{f.particles_per_s(path) / 1e6:.2f}")]
        rows.append((f"{f.particles:,}", *timings, f"{f.checksum_s * 1e3:.2f}",
                     format_ratio("gs_tf_vs_numpy", f.gs_tf_vs_numpy),
                     format_ratio("gs_tf_vs_compute", f.gs_tf_vs_compute),
                     format_ratio("checksum_share", f.checksum_share)))
    return rows


def target_line(target: dict) -> str:
    """'gs_tf_vs_numpy >= 10 at 1,000,000 particles: measured 23.10x - met'."""
    measured = format_ratio(target["name"], target["measured"])
    verdict = "met" if target["met"] else "NOT met"
    return (f"{target['name']} {target['comparison']} {target['target']:g} at "
            f"{target['particles']:,} particles: measured {measured} - {verdict}")


def build_report(scene: Scene, gl: dict[str, str], frames: int,
                 sizes: list[SizeFigures]) -> dict[str, object]:
    return {
        "command": "bench",
        "scene": {"name": scene.name, "source": str(scene.source) if scene.source else None},
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "frames": frames,
        "sizes": [figures.to_json() for figures in sizes],
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
