"""The frame logs in tests/data/logs, recorded on Mesa's llvmpipe in portable arithmetic,
replay bit for bit: here in CI, and on any GPU through deploy/gpu-check.sh. They are of
frame log version 3 (wire version 10 envelopes), read by the log's legacy reader."""

from pathlib import Path

import pytest

from cavesim.core.framelog import FrameLogWriter, read_frame_log
from cavesim.core.scene import load_scene
from cavesim.core.scene.model import Arithmetic
from cavesim.tools.log_replay import replay

ROOT = Path(__file__).resolve().parents[2]
LOGS = sorted((ROOT / "tests" / "data" / "logs").glob("*.log"))


def test_two_logs_are_shipped():
    assert [log.stem for log in LOGS] == ["downwash_portable", "vortex_portable"]


@pytest.mark.parametrize("log", LOGS, ids=lambda log: log.stem)
def test_a_shipped_log_names_its_portable_scene_beside_it(log):
    header, frames = read_frame_log(log)
    scene = ROOT / header["scene"]
    assert scene == log.with_suffix(".toml") and frames.damage is None
    assert load_scene(scene).arithmetic is Arithmetic.PORTABLE  # the same bits on any GPU


@pytest.mark.parametrize("log", LOGS, ids=lambda log: log.stem)
def test_a_shipped_log_written_again_as_version_4_holds_the_same_frames(tmp_path, log):
    """What the legacy reader reads, the version 4 writer keeps: every field of every frame
    comes back the same from the new log (so a replay of it steps the same inputs)."""
    header, frames = read_frame_log(log)
    writer = FrameLogWriter(tmp_path / "again.log", header)
    for logged in frames:
        writer.append(logged.message, logged.digest, logged.particles)
    writer.close()
    again_header, again = read_frame_log(tmp_path / "again.log")
    assert again_header == {**header, "version": 4} and again.damage is None
    assert [repr(f) for f in again] == [repr(f) for f in frames]


@pytest.mark.parametrize("log", LOGS, ids=lambda log: log.stem)
def test_a_shipped_log_replays_every_checksum(ctx, log):
    header, _ = read_frame_log(log)
    result = replay(log, ROOT / header["scene"], ctx)
    assert result.frames == 120 and result.mismatches == [] and result.equal
