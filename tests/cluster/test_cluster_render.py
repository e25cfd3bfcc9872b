"""Rendering in the cluster: walls at different resolutions stay consistent; `cavesim run`
writes wall images, unfolded-CAVE composites and an animation."""

import json
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest
from master_process import spawn_master
from PIL import Image

from nodes.launch.launcher import LocalCluster

ROOT = Path(__file__).parents[2]
DUST_DEVIL = ROOT / "config" / "scenes" / "dust_devil.toml"

pytestmark = pytest.mark.slow

MIXED_CAVE = """
name = "mixed"
[[wall]]
name = "front"
lower_left = [-1.5, 1.5, 0.0]
lower_right = [1.5, 1.5, 0.0]
upper_left = [-1.5, 1.5, 3.0]
resolution = [160, 160]
[[wall]]
name = "left"
lower_left = [-1.5, -1.5, 0.0]
lower_right = [-1.5, 1.5, 0.0]
upper_left = [-1.5, -1.5, 3.0]
resolution = [48, 48]
"""


def test_walls_at_different_resolutions_stay_consistent(tmp_path):
    cave = tmp_path / "mixed.toml"
    cave.write_text(MIXED_CAVE)
    extra = ("--cave", str(cave), "--render-every", "5", "--images", str(tmp_path / "walls"))
    with LocalCluster(DUST_DEVIL, tmp_path, f"mixed{os.getpid()}") as cluster:
        for wall in ("front", "left"):
            cluster.start_node(wall, extra=extra)
        master = spawn_master(cluster, ("front", "left"), 60)
        master.stdout.read()
        assert master.wait(timeout=120) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["frames"] == 60 and report["divergences"] == []
    for wall, size in (("front", (160, 160)), ("left", (48, 48))):
        pictures = sorted((tmp_path / "walls" / wall).glob("frame_*.png"))
        assert len(pictures) == 12
        assert Image.open(pictures[-1]).size == size


def test_cavesim_run_writes_walls_composites_and_an_animation(tmp_path):
    command = [sys.executable, "-m", "cavesim", "run", "--frames", "40", "--render-every",
               "20", "--stereo", "--out", str(tmp_path), "--session", f"pics{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["divergences"] == [] and report["images"]["composites"] == 2
    composite = Image.open(tmp_path / "composites" / "composite_000040.png")
    assert composite.size == (1440, 960)  # left | front | right over the floor, 480 px each
    animation = Image.open(tmp_path / "run.gif")  # small, and at the run's own pace:
    assert animation.n_frames == 2 and animation.size == (480, 320)
    assert animation.info["duration"] == 330  # ms: 20 frames of 1/60 s (in centiseconds)
    video = imageio.get_reader(tmp_path / "run.mp4")
    assert video.count_frames() == 2 and video.get_meta_data()["fps"] == 3.0
    assert report["images"]["video"] == str(tmp_path / "run.mp4")
    assert "wrote 2 composites, " in result.stdout and "pictures" in result.stdout
    for wall in ("front", "left", "right", "floor"):
        left_eye = np.asarray(Image.open(tmp_path / "walls" / wall / "frame_000040.png"))
        right_eye = np.asarray(Image.open(tmp_path / "walls" / wall / "frame_000040_right.png"))
        assert left_eye.shape == right_eye.shape
        # the ground lies in the floor screen's own plane: no parallax there, by design;
        # only its fog, which grows with the distance from each eye, may differ a level
        step = np.abs(left_eye.astype(int) - right_eye.astype(int)).max()
        assert (step <= 1) == (wall == "floor"), (wall, step)
