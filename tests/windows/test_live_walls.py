"""Live walls under a real X server (Xvfb, Mesa, GLFW): a window shows the headless
render's pixels, four windows swap together, closing one loses that wall, and the preview
window's keys move the head as a tracker would and pause, reset and end the run; a node of
two walls shows them side by side."""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from xserver import close_window, hold_key, window_id, xdotool, xserver  # noqa: F401  (a fixture)

from cavesim.core.cave.desktop import desktop_cave_file
from cavesim.core.cave.geometry import load_cave
from cavesim.core.cave.projection import eye_positions
from cavesim.core.drivers import driver_for
from cavesim.core.framelog import read_frame_log
from cavesim.core.scene import load_scene
from cavesim.core.wire.credentials import generate
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.wall_renderer import WallRenderer
from cavesim.tools.log_replay import replay
from nodes.commands.run import RunPlan
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.master.process import MasterConfig

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
DUST_DEVIL = ROOT / "config" / "scenes" / "dust_devil.toml"
FLEX4 = ROOT / "config" / "cave" / "flex4.toml"


def live_cave(folder: Path, walls: tuple[str, ...], size: int = 64) -> Path:
    """A CAVE file whose flex4 walls open side by side as `size`-pixel windows, no vsync."""
    path = folder / "live.toml"
    path.write_text(desktop_cave_file(load_cave(FLEX4), walls, size))
    return path


def live_run(folder: Path, scene: Path, walls: tuple[str, ...], frames: int, args,
             before_frame=None):
    """Run a cluster whose walls show live with `args`; the master's RunRecord."""
    config = MasterConfig(walls, scene, frames, f"live{os.getpid()}{folder.name[-6:]}",
                          barrier_timeout=5.0, frame_log=folder / "frames.log")
    node_args = {wall: args(wall) for wall in walls}
    return run_cluster(ClusterPlan(config, folder, node_args=node_args),
                       before_frame=before_frame)


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_a_window_shows_the_pixels_of_the_headless_render(xserver, ctx, tmp_path):  # noqa: F811
    cave = live_cave(tmp_path, ("front",), size=96)
    record = live_run(tmp_path, DUST_DEVIL, ("front",), 20, lambda wall: (
        "--display", "--cave", str(cave), "--render-every", "10", "--images",
        str(tmp_path / "walls")))
    assert record.frames == 20 and record.swaps.summary()["frames"] >= 19
    shown = np.asarray(Image.open(tmp_path / "walls" / "front" / "frame_000020.png"))

    scene = load_scene(DUST_DEVIL)  # the same frame, drawn headless in this process
    system, driver = ParticleSystem(ctx, scene), driver_for(scene)
    for logged in read_frame_log(tmp_path / "frames.log")[1]:
        system.step(logged.message.inputs, driver.decode(logged.message.params))
        if logged.message.frame == 20:
            message = logged.message
            break
    renderer = WallRenderer(ctx, system, load_cave(cave).wall("front"))
    (eye,) = eye_positions(message.head.position, message.head.orientation).values()
    headless = renderer.render(eye, driver.decode(message.params).helicopter)
    assert shown.shape == headless.shape == (96, 96, 3)
    assert np.array_equal(shown, headless), f"{(shown != headless).any(axis=2).sum()} pixels"
    assert headless.std() > 5  # a picture, not a blank


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_a_node_of_two_walls_shows_each_headless_render_in_its_viewport(xserver, ctx,  # noqa: F811
                                                                        tmp_path):
    walls = ("front", "left")
    cave = live_cave(tmp_path, walls, size=80)
    record = live_run(tmp_path, DUST_DEVIL, ("pair",), 20, lambda node: (
        "--display", "--cave", str(cave), "--draws", ",".join(walls), "--render-every", "20",
        "--images", str(tmp_path / "walls")))
    assert record.frames == 20 and record.swaps.summary()["walls"] == ["pair"]

    scene = load_scene(DUST_DEVIL)
    system, driver = ParticleSystem(ctx, scene), driver_for(scene)
    for logged in read_frame_log(tmp_path / "frames.log")[1]:
        system.step(logged.message.inputs, driver.decode(logged.message.params))
    message = logged.message
    (eye,) = eye_positions(message.head.position, message.head.orientation).values()
    for wall in walls:
        shown = np.asarray(Image.open(tmp_path / "walls" / wall / "frame_000020.png"))
        renderer = WallRenderer(ctx, system, load_cave(cave).wall(wall))
        headless = renderer.render(eye, driver.decode(message.params).helicopter)
        assert shown.shape == headless.shape == (80, 80, 3)
        assert np.array_equal(shown, headless), wall
        assert headless.std() > 5, wall


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_four_windows_swap_only_after_every_wall_has_drawn(xserver, tmp_path):  # noqa: F811
    walls = ("front", "left", "right", "floor")
    cave = live_cave(tmp_path, walls)
    record = live_run(tmp_path, MINIMAL, walls, 40, lambda wall: (
        "--display", "--cave", str(cave)))
    swap = record.summary()["swap"]
    print(f"\nfour windows under Xvfb (llvmpipe): swap skew p50 {swap['skew_ms']['p50']} ms, "
          f"p99 {swap['skew_ms']['p99']} ms over {swap['frames']} frames")
    assert swap["walls"] == sorted(walls) and swap["frames"] >= 39
    assert swap["order_violations"] == 0 and swap["stalls"] == []
    assert not record.divergences and record.final.agree and record.final.all_walls_in


@pytest.mark.slow
@pytest.mark.requires("xvfb", "xdotool")
def test_closing_a_wall_window_stops_that_node_and_loses_the_wall(xserver, tmp_path):  # noqa: F811
    walls = ("front", "left", "right")
    cave = live_cave(tmp_path, walls)

    def close_left(cluster, k):
        if k == 10:
            close_window(window_id("cavesim left"))

    record = live_run(tmp_path, MINIMAL, walls, 60, lambda wall: (
        "--display", "--cave", str(cave)), before_frame=close_left)
    assert record.frames == 60 and [loss.node for loss in record.losses] == ["left"]
    assert record.final.members == ("front", "right") and record.final.agree
    assert "the window was closed; leaving" in (tmp_path / "logs" / "left.log").read_text()


@pytest.mark.slow
@pytest.mark.requires("xvfb", "xdotool")
def test_the_preview_window_flies_pauses_resets_and_ends_the_run(xserver, ctx,  # noqa: F811
                                                                   tmp_path):
    """Its keys move the head as a tracker would; P pauses every node on one frame (dt 0) and
    resumes them, the title says the frame, the rate and the pause; R takes every node back
    to the start on one frame, and the run replays bit for bit from its frame log; Esc ends
    the run cleanly between two frames. With keys, as `cavesim run --preview --key-file`
    plans it: the preview signs with the operator's key the run issued it, and the record
    names that operator for each control."""
    cave = live_cave(tmp_path, ("front", "left", "right", "floor"))
    titles = []

    def keys(cluster, k):
        if k == 5:
            hold_key(window_id("cavesim preview"), "Up", 1.0)  # forward, 1 m/s
        elif k in (10, 20, 25, 30):  # each press has reached the master when frame k is made
            preview = window_id("cavesim preview")
            if k == 20:
                titles.append(xdotool("getwindowname", str(preview)))
            hold_key(preview, {10: "p", 20: "p", 25: "r", 30: "Escape"}[k], 0.1)
            time.sleep(0.5)

    plan = RunPlan({"front": ("front",)}, MINIMAL, 60, tmp_path, f"preview{os.getpid()}",
                   generate(), cave=cave, render_every=0, preview=True)
    record = run_cluster(plan.cluster(), before_frame=keys)
    assert record.user_stopped and record.frames == 29
    assert record.final.agree and record.final.all_walls_in and not record.losses
    assert [(a.frame, a.action, a.by) for a in record.user_actions] == [
        (10, "pause", "operator preview"), (20, "resume", "operator preview"),
        (25, "reset", "operator preview"), (30, "stop", "operator preview")]
    frames = [logged.message for logged in read_frame_log(tmp_path / "frames.log")[1]]
    heads = [frame.head.position for frame in frames]
    assert abs(heads[3][1]) < 1e-6  # the script's sway moves the head sideways only
    assert max(y for _, y, _ in heads[6:]) > 0.5  # the tracked head went forward
    assert [k for k, frame in enumerate(frames, 1) if frame.inputs.dt == 0] == list(range(10, 20))
    assert [k for k, frame in enumerate(frames, 1) if frame.reset] == [25]
    assert re.fullmatch(r"cavesim preview - frame 1\d - [\d.]+ frames/s - paused", titles[0])
    replayed = replay(tmp_path / "frames.log", ctx=ctx)
    assert replayed.frames == 29 and replayed.equal, replayed.mismatches[:3]


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_walls_without_a_window_open_side_by_side(xserver, tmp_path):  # noqa: F811
    """A CAVE file with no [wall.display]: each node places its window after the walls the
    file lists before its own (cavesim.core.cave.desktop.tiled_window)."""
    walls = ("front", "left", "right")
    cave = tmp_path / "plain.toml"
    cave.write_text("\n".join(line for line in live_cave(tmp_path, walls).read_text().split("\n")
                              if not line.startswith("display")))
    places = {}

    def look(cluster, k):
        if k == 3:
            for wall in walls:
                geometry = xdotool("getwindowgeometry", str(window_id(f"cavesim {wall}")))
                places[wall] = geometry.split("Position: ")[1].split(" ")[0]

    live_run(tmp_path, MINIMAL, walls, 5, lambda wall: ("--display", "--cave", str(cave)),
             before_frame=look)
    assert places == {"front": "0,0", "left": "72,0", "right": "144,0"}  # 64 px + 8 px apart
