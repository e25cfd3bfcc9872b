"""`cavesim bench --cluster`'s swap barrier: 2 and 4 walls live in small windows, swap-locked,
on one X server; the swap skew (latest - earliest swap of a frame) from the run's report.

The windows open on DISPLAY when one is set (a real desktop: the skew then includes its
compositor), else on an Xvfb of our own; with neither, the measurement is skipped and says
why. Each node draws its wall at SWAP_WINDOW_PX pixels without vsync, so the figure is the
barrier's own: no vertical blank to wait for.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

from cavesim.core.cave.desktop import desktop_cave_file
from cavesim.core.cave.geometry import load_cave
from cavesim.tools.xvfb import XServerError, virtual_display
from nodes.cluster_bench.metered_run import Tick, cluster_run

SWAP_WALL_COUNTS = (2, 4)
SWAP_WALLS = ("front", "left", "right", "floor")  # of the CAVE file given
SWAP_WINDOW_PX = 64


def measure_swap(scene: Path, cave_file: Path, frames: int, runs_dir: Path,
                 ticker: Callable[[str], Tick]) -> dict[str, object]:
    """{"x_server", "window_px", "runs": one per wall count} or {"skipped": why}."""
    with ExitStack() as stack:
        if os.environ.get("DISPLAY"):
            x_server = f"DISPLAY {os.environ['DISPLAY']}"
        else:
            try:
                x_server = f"Xvfb {stack.enter_context(virtual_display())}"
            except XServerError as e:
                return {"skipped": f"no X display: DISPLAY is not set and {e}"}
        cave = load_cave(cave_file)
        runs = []
        for count in SWAP_WALL_COUNTS:
            walls = SWAP_WALLS[:count]
            run_dir = runs_dir / f"swap-{count}"
            run_dir.mkdir(parents=True, exist_ok=True)
            windows = run_dir / "desktop.toml"
            windows.write_text(desktop_cave_file(cave, walls, SWAP_WINDOW_PX))
            runs.append(cluster_run(scene, walls, frames, run_dir,
                                    ticker(f"swap barrier, {count} windows"),
                                    ("--display", "--cave", str(windows)), draws=True))
    return {"x_server": x_server, "window_px": SWAP_WINDOW_PX, "scene": str(scene),
            "runs": runs}
