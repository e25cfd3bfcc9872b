"""`cavesim render` draws a run's pictures again from its frame log: the same bytes the walls
drew, only the frames asked for, at the scale asked for, checked against every logged
checksum and stopped at the first that differs; bad input is one line, nothing drawn."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from cavesim.core.framelog import FrameLogWriter, read_frame_log
from nodes import cli
from nodes.arguments import RUN_ERROR, USAGE_ERROR

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
VORTEX = ROOT / "tests" / "data" / "logs" / "vortex_portable.log"  # 120 frames
TINY_CAVE = """name = "tiny"

[[wall]]
name = "front"
lower_left = [-1.5, 1.5, 0.0]
lower_right = [1.5, 1.5, 0.0]
upper_left = [-1.5, 1.5, 2.5]
resolution = [60, 50]

[[wall]]
name = "floor"
lower_left = [-1.5, -1.5, 0.0]
lower_right = [1.5, -1.5, 0.0]
upper_left = [-1.5, 1.5, 0.0]
resolution = [60, 60]
"""
pytestmark = pytest.mark.xdist_group("render")  # one small run, on one worker


@pytest.fixture(scope="module")
def tiny_cave(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cave") / "tiny.toml"
    path.write_text(TINY_CAVE)
    return path


@pytest.fixture(scope="module")
def drawn_run(tmp_path_factory, tiny_cave) -> Path:
    """A run of two small walls that drew every 5th of 20 frames."""
    out = tmp_path_factory.mktemp("run") / "run"
    done = subprocess.run([sys.executable, "-m", "cavesim", "run", "--cave", str(tiny_cave),
                           "--scene", str(MINIMAL), "--frames", "20", "--render-every", "5",
                           "--out", str(out), "--session", f"render{os.getpid()}"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def pictures(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*.png"))}


def test_the_pictures_are_the_bytes_the_walls_drew(drawn_run, tiny_cave, tmp_path, capsys):
    out = tmp_path / "render"
    assert cli.main(["render", str(drawn_run), "--cave", str(tiny_cave), "--every", "5",
                     "--video", "--out", str(out)]) == 0
    assert "20 frames re-run: every checksum reproduced" in capsys.readouterr().out
    drawn = pictures(out / "walls")
    assert len(drawn) == 8 and drawn == pictures(drawn_run / "walls")
    assert pictures(out / "composites") == pictures(drawn_run / "composites")
    assert (out / "render.mp4").stat().st_size > 0 and (out / "render.gif").stat().st_size > 0
    summary = json.loads((out / "render.json").read_text())
    assert summary["equal"] and summary["frames"] == 20 and summary["pictures"] == 8


def test_only_the_frames_asked_are_drawn_at_the_scale_asked(tiny_cave, tmp_path):
    out = tmp_path / "render"
    assert cli.main(["render", str(VORTEX), "--scene", str(VORTEX.with_suffix(".toml")),
                     "--cave", str(tiny_cave), "--frames", "7:17", "--every", "4",
                     "--scale", "0.5", "--out", str(out)]) == 0
    assert sorted(p.name for p in (out / "walls" / "front").iterdir()) == [
        "frame_000008.png", "frame_000012.png", "frame_000016.png"]
    with Image.open(out / "walls" / "front" / "frame_000008.png") as picture:
        assert picture.size == (30, 25)
    assert len(list((out / "composites").iterdir())) == 3
    assert not list(out.glob("render.*[4f]"))  # no video without --video
    summary = json.loads((out / "render.json").read_text())
    assert summary["frames"] == 17 and summary["frames_drawn"] == [7, 17]


def test_a_frame_whose_checksum_differs_stops_the_render(tiny_cave, tmp_path, capsys):
    header, frames = read_frame_log(VORTEX)
    tampered = tmp_path / "run" / "frames.log"
    tampered.parent.mkdir()
    writer = FrameLogWriter(tampered, {k: v for k, v in header.items()
                                       if k not in ("format", "version")})
    for logged in frames:
        digest = "0" * 32 if logged.message.frame == 13 else logged.digest
        writer.append(logged.message, digest, logged.particles)
    writer.close()
    out = tmp_path / "render"
    assert cli.main(["render", str(tampered.parent), "--scene", str(VORTEX.with_suffix(".toml")),
                     "--cave", str(tiny_cave), "--every", "4", "--out", str(out)]) == RUN_ERROR
    told = capsys.readouterr().out
    assert "13 frames re-run: 1 frame(s) differ, first at 13" in told
    assert "the render stopped at frame 13, whose checksum differs from the log's" in told
    assert sorted(p.name for p in (out / "walls" / "front").iterdir()) == [
        "frame_000004.png", "frame_000008.png", "frame_000012.png"]
    assert json.loads((out / "render.json").read_text())["mismatch_count"] == 1


@pytest.mark.parametrize(("flags", "message"), [
    (["--frames", "100:130"], "argument --frames: the log holds frames 1..120, got 100:130"),
    (["--frames", "9:3"], "argument --frames: expected frames A:B, A: or :B with 1 <= A <= B, "
                          "got '9:3'"),
    (["--frames", "12:13", "--every", "5"], "argument --every: no frame in 12:13 is a multiple "
                                           "of 5"),
    (["--scale", "0"], "argument --scale: expected a scale in [0.01, 4.0], got '0'"),
])
def test_bad_flags_are_one_line_and_draw_nothing(tmp_path, capsys, flags, message):
    out = tmp_path / "render"
    assert cli.main(["render", str(VORTEX), "--scene", str(VORTEX.with_suffix(".toml")),
                     *flags, "--out", str(out)]) == USAGE_ERROR
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"cavesim render: error: {message}")
    assert not out.exists()


def test_the_runs_own_folder_is_never_the_renders(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "frames.log").write_bytes(VORTEX.read_bytes())
    assert cli.main(["render", str(run), "--out", str(run), "--force"]) == USAGE_ERROR
    assert f"argument --out: {str(run)!r} holds the frame log it would draw" in \
        capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == ["frames.log"]
    assert cli.main(["render", str(tmp_path / "nothing")]) == USAGE_ERROR
    assert "argument log: no file" in capsys.readouterr().err
