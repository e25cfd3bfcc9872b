"""A scene whose flow is a NetCDF time series, as processes: the master's clock moves the
field through its snapshots, the walls stay identical and the frame log replays bit for
bit; the sand thrown out of the field's box is counted per frame and class in report.json
and warned about once; the smoke's substeps (tracers by RK45) are counted there too."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cavesim.tools.log_replay import replay

ROOT = Path(__file__).parents[2]
FRAMES = 150  # 2.5 s: the pulsing vortex's snapshots 0 to 5
SCENE = f"""
name = "pulsing"

[simulation]
capacity = 3000
seed = 5
integrator = "etd2rk"
tracer_method = "rk45"
tracer_tolerance = 1e-8

[[particle_class]]
name = "sand"
diameter = 150e-6
density = 2650.0

[[particle_class]]
name = "dust"
diameter = 20e-6
density = 2650.0

[[particle_class]]
name = "smoke"
diameter = 1e-5
motion = "tracer"

[[emitter]]
name = "smoker"
position = [0.0, 1.0, 2.0]
rate = 200.0
speed = 0.5
lifetime = [1.0, 2.0]
particle_class = "smoke"

[[emitter]]
name = "thrower"
position = [5.6, 0.0, 2.0]
rate = 400.0
speed = 6.0
speed_spread = 1.0
direction = [1.0, 0.0, 0.3]
spread_angle = 10.0
lifetime = [2.0, 3.0]
particle_class = "sand"

[forces]
gravity = [0.0, 0.0, -9.81]
drag = {{}}

[field]
kind = "file"
file = "{ROOT / 'config' / 'fields' / 'pulsing_vortex.nc'}"
"""


@pytest.mark.slow
def test_a_time_series_scene_runs_identical_walls_and_counts_the_sand_leaving(tmp_path, ctx):
    scene = tmp_path / "pulsing.toml"
    scene.write_text(SCENE)
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", str(FRAMES),
               "--scene", str(scene), "--render-every", "0", "--out", str(tmp_path / "out"),
               "--session", f"series{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["divergences"] == [] and report["frames"] == FRAMES
    counters = report["counters"]
    assert counters["values_from"] == "agreed" and counters["unknown_ids_skipped"] == {}
    exits = counters["domain_exits"]
    assert exits["classes"] == ["sand", "dust", "smoke"]
    assert exits["total"]["sand"] > 100 and exits["total"]["dust"] == 0
    assert len(exits["per_frame"]) == FRAMES and exits["frames_not_counted"] == 0
    assert exits["frames_unagreed"] == 0
    assert sum(counts["sand"] for counts in exits["per_frame"]) == exits["total"]["sand"]
    first = exits["first_frame"]["sand"]
    assert f"{exits['total']['sand']:,} sand from frame {first}" in result.stdout
    taken, tracers = counters["substeps_taken"], counters["tracers_stepped"]
    assert taken["frames_not_counted"] == 0 and len(taken["per_frame"]) == FRAMES
    assert taken["total"] > tracers["total"] > 100 and counters["substeps_retaken"]["total"] > 0
    assert f"{taken['total']:,} substeps" in result.stdout
    master_log = (tmp_path / "out" / "logs" / "master.log").read_text()
    assert master_log.count("particles left the field's box") == 1
    assert f"frame {first}: particles left the field's box [-6.0, -6.0, 0.0]" in master_log
    logged = replay(tmp_path / "out" / "frames.log", scene, ctx=ctx)
    assert logged.frames == FRAMES and logged.equal, logged.mismatches[:2]
