"""`cavesim run` reports what drawing a wall cost, over the frames each node drew: a node
drawing every 2nd frame has a render p50 of 0 over all its frames, and not over these."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
TWO_WALLS = """name = "two"

[[wall]]
name = "front"
lower_left = [-1.5, 1.5, 0.0]
lower_right = [1.5, 1.5, 0.0]
upper_left = [-1.5, 1.5, 3.0]
resolution = [48, 48]

[[wall]]
name = "floor"
lower_left = [-1.5, -1.5, 0.0]
lower_right = [1.5, -1.5, 0.0]
upper_left = [-1.5, 1.5, 0.0]
resolution = [48, 48]
"""
pytestmark = pytest.mark.xdist_group("render_cost_run")  # one small run, on one worker


def test_report_has_each_walls_render_cost_over_its_drawn_frames(tmp_path):
    cave = tmp_path / "two.toml"
    cave.write_text(TWO_WALLS)
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "cavesim", "run", "--cave", str(cave),
                           "--scene", str(MINIMAL), "--frames", "8", "--render-every", "2",
                           "--out", str(out), "--session", f"rendercost{os.getpid()}"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    report = json.loads((out / "report.json").read_text())
    per_wall = report["render_ms_per_wall"]
    assert set(per_wall) == {"front", "floor"}
    for node, cost in per_wall.items():
        assert cost["walls"] == [node]
        # frames 2, 4 and 6 drawn: each carried by the next frame's report (8's by none)
        assert cost["drawn_frames"] == 3
        assert 0 < cost["p50"] <= cost["p99"] <= cost["max"]
        # over every frame: the undrawn frames' 0, to the histogram's smallest bin
        assert report["frame_cost_ms"][node]["render"]["p50"] <= 0.001 < cost["p50"]
    assert "render per wall, drawn frames" in done.stdout
