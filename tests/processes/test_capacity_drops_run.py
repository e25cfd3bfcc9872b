"""A scene whose emission outgrows its capacity, as `cavesim run` processes: the terminal
says once that particles were dropped, at the first frame and how many, report.json counts
every frame's and the run's table has the total."""

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[2]
FRAMES = 40
SCENE = """
name = "overflow"

[simulation]
capacity = 300
seed = 1
integrator = "semi_implicit_euler"

[[particle_class]]
name = "drop"
diameter = 2e-3
density = 1000.0

[[emitter]]
name = "fountain"
position = [0.0, 0.0, 1.0]
rate = 3000.0
speed = 4.0
speed_spread = 0.5
direction = [0.0, 0.0, 1.0]
spread_angle = 15.0
lifetime = [1.0, 2.0]
particle_class = "drop"

[forces]
gravity = [0.0, 0.0, -9.81]
"""


def test_an_overflowing_scene_says_so_once_and_counts_every_drop(tmp_path):
    """50 new drops a frame into 300 places, none dying within the run's 40 frames: full
    after frame 6, then each frame's 50 dropped (3,000 per second)."""
    scene = tmp_path / "overflow.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", str(FRAMES),
               "--scene", str(scene), "--render-every", "0", "--out", str(out),
               "--session", f"overflow{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["divergences"] == [] and report["frames"] == FRAMES
    assert report["live_per_frame"][:7] == [50, 100, 150, 200, 250, 300, 300]
    assert report["capacity"] == 300
    drops = report["counters"]["capacity_drops"]
    assert drops["first_frame"] == 7 and drops["total"] == 50 * (FRAMES - 6)
    assert drops["per_frame"] == [0] * 6 + [50] * (FRAMES - 6)
    assert drops["per_frame_stride"] == 1 and drops["frames_not_counted"] == 0
    line = ("capacity full: 50 new particles dropped at frame 7 (the scene holds 300); "
            "report.json counts every frame's (counters.capacity_drops)")
    assert result.stdout.count("capacity full:") == 1 and line in result.stdout
    assert "1,700 particles from frame 7" in result.stdout
    assert (out / "logs" / "master.log").read_text().count(line) == 1
