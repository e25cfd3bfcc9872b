"""The frame log outlives its writer: every whole record is read back, a torn tail or a
corrupt record is found and located, and `cavesim replay` replays every whole record
before it (a torn tail passes, a corrupt record fails)."""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
import pytest

from cavesim.core.drivers import driver_for
from cavesim.core.errors import OutputError
from cavesim.core.framelog import (
    CORRUPT,
    TORN,
    Damage,
    FrameLogError,
    FrameLogWriter,
    read_frame_log,
)
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import load_scene
from cavesim.core.wire import FrameMessage
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.tools.log_replay import replay
from nodes import cli
from nodes.arguments import RUN_ERROR, USAGE_ERROR
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.master.process import MasterConfig

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
FRAMES = 6
REAL_FRAMES = 40
pytestmark = pytest.mark.xdist_group("framelog")  # one real log, on one worker


def record_spans(data: bytes) -> list[tuple[int, int]]:
    """[start, end) of every record, walked by the documented layout: size, its check,
    payload, the payload's check."""
    spans, offset = [], data.index(b"\n") + 1
    while offset < len(data):
        (size,) = struct.unpack_from("<I", data, offset)
        spans.append((offset, offset + 8 + size + 4))
        offset = spans[-1][1]
    return spans


def write_log(path: Path, frames: int = FRAMES) -> bytes:
    writer = FrameLogWriter(path, {"session": "t", "scene": str(MINIMAL)})
    for k in range(1, frames + 1):
        writer.append(FrameMessage(k, FrameInput(1 / 60, np.eye(3))), f"{k:032x}", 100 * k)
    writer.close()
    return path.read_bytes()


def test_a_whole_log_reads_back_every_frame(tmp_path):
    write_log(tmp_path / "frames.log")
    header, frames = read_frame_log(tmp_path / "frames.log")
    assert header["version"] == 4 and frames.damage is None and len(frames) == FRAMES
    assert [(f.message.frame, f.digest, f.particles) for f in frames] == \
        [(k, f"{k:032x}", 100 * k) for k in range(1, FRAMES + 1)]


def test_every_record_is_on_disk_as_soon_as_it_is_appended(tmp_path):
    writer = FrameLogWriter(tmp_path / "frames.log", {"session": "t"})
    for k in (1, 2):
        writer.append(FrameMessage(k, FrameInput(1 / 60, np.eye(3))), "ab" * 16, k)
        _, frames = read_frame_log(tmp_path / "frames.log")  # another reader, mid-run
        assert len(frames) == k and frames.damage is None
    writer.close()


# where the writer stopped inside the last record: bytes of it that reached the file
CUTS = {"mid-size": lambda size: 2, "mid-size-check": lambda size: 6,
        "mid-payload": lambda size: size // 2, "mid-payload-check": lambda size: size - 2,
        "one-byte-short": lambda size: size - 1}


@pytest.mark.parametrize("cut", CUTS)
def test_a_torn_tail_keeps_every_whole_record_and_says_where_it_is(tmp_path, cut):
    data = write_log(tmp_path / "whole.log")
    start, end = record_spans(data)[-1]
    kept = CUTS[cut](end - start)
    (tmp_path / "torn.log").write_bytes(data[:start + kept])
    _, frames = read_frame_log(tmp_path / "torn.log")
    assert [f.message.frame for f in frames] == list(range(1, FRAMES))
    assert frames.damage == Damage(TORN, start, kept, FRAMES - 1)


# a flipped byte in the third record, counted from the record's start or end
FLIPS = {"size": 1, "size-check": 5, "payload": 20, "payload-check": -2}


@pytest.mark.parametrize("flip", FLIPS)
def test_a_flipped_byte_in_a_middle_record_is_found_and_nothing_after_it_is_read(tmp_path,
                                                                              flip):
    data = bytearray(write_log(tmp_path / "whole.log"))
    start, end = record_spans(bytes(data))[2]
    data[(start if FLIPS[flip] >= 0 else end) + FLIPS[flip]] ^= 0x10
    (tmp_path / "flipped.log").write_bytes(data)
    _, frames = read_frame_log(tmp_path / "flipped.log")
    assert [f.message.frame for f in frames] == [1, 2]
    assert frames.damage == Damage(CORRUPT, start, len(data) - start, 2)


@pytest.mark.parametrize(("content", "message"), [
    (b"", "not a cavesim frame log"), (b'{"format": "cavesim-frame-l', "not a cavesim frame log"),
    (b'{"format": "cavesim-frame-log", "version": 1, "session": "t"}\n',
     "version 1; this build reads versions 3 and 4"),
    (b'{"format": "cavesim-frame-log", "version": 2, "session": "t"}\n',
     "version 2; this build reads versions 3 and 4"),
])
def test_a_file_that_is_no_log_this_build_reads_is_refused_by_name(tmp_path, content,
                                                                   message):
    (tmp_path / "frames.log").write_bytes(content)
    with pytest.raises(FrameLogError, match=message):
        read_frame_log(tmp_path / "frames.log")


@pytest.mark.parametrize("command", ["replay", "render"])
def test_replay_and_render_refuse_a_version_2_log_in_one_line(tmp_path, capsys, command):
    log = tmp_path / "frames.log"
    log.write_bytes(b'{"format": "cavesim-frame-log", "version": 2, "session": "t"}\n')
    assert cli.main([command, str(log), "--scene", str(MINIMAL)]) == USAGE_ERROR
    (line,) = capsys.readouterr().err.splitlines()
    assert line == (f"cavesim {command}: error: argument log: {log}: cavesim-frame-log "
                    f"version 2; this build reads versions 3 and 4 (a version 1 or 2 log is "
                    f"replayed by the build that wrote it)")


def test_a_full_disk_is_an_output_error_naming_the_log():
    with pytest.raises(OutputError, match=r"^cannot write /dev/full: No space left on device$"):
        FrameLogWriter(Path("/dev/full"), {"session": "t"})


def test_a_log_deleted_while_it_was_written_is_not_claimed(tmp_path):
    writer = FrameLogWriter(tmp_path / "frames.log", {"session": "t"})
    os.unlink(tmp_path / "frames.log")
    with pytest.raises(OutputError, match="frames.log: it was deleted while the run wrote it"):
        writer.close()


def test_a_log_with_a_reset_replays_and_the_reset_is_the_start_state(tmp_path, ctx):
    """A reset frame takes every node back to the scene's start state before its step: after
    it, the inputs of frames 1, 2, ... give their checksums again, and a replay reproduces
    every one."""
    scene = load_scene(MINIMAL)
    system, driver = ParticleSystem(ctx, scene), driver_for(scene)
    rng = np.random.Generator(np.random.PCG64(5))
    inputs = [(FrameInput(1 / 60, draw_transform(rng, scene.random_texture_size)),
               driver.encode(driver.advance(k / 60, 1 / 60, None).frame)) for k in range(1, 9)]
    writer = FrameLogWriter(tmp_path / "reset.log", {"session": "t", "scene": str(MINIMAL)})
    digests = []
    for k, (frame, params) in enumerate(inputs + inputs[:5], start=1):
        reset = k == len(inputs) + 1
        if reset:
            system.restart(scene.seed)
        system.step(frame, driver.decode(params))
        state = system.checksum()
        digests.append(state.digest)
        writer.append(FrameMessage(k, frame, params=params, reset=reset), state.digest,
                      state.particles)
    writer.close()
    system.release()
    assert digests[8:] == digests[:5] and digests[8] != digests[7]
    result = replay(tmp_path / "reset.log", MINIMAL, ctx=ctx)
    assert result.frames == 13 and result.equal, result.mismatches[:3]


@pytest.fixture(scope="module")
def real_log(tmp_path_factory) -> bytes:
    """A frame log the master wrote in a real two-wall run."""
    out = tmp_path_factory.mktemp("run")
    config = MasterConfig(("front", "left"), MINIMAL, REAL_FRAMES, f"log{os.getpid()}",
                          frame_log=out / "frames.log")
    assert run_cluster(ClusterPlan(config, out)).frames == REAL_FRAMES
    return (out / "frames.log").read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize("cut", ["mid-size", "mid-payload", "mid-payload-check"])
def test_a_real_log_cut_anywhere_in_its_last_record_replays_every_whole_one(tmp_path, ctx,
                                                                           real_log, cut):
    start, end = record_spans(real_log)[-1]
    (tmp_path / "torn.log").write_bytes(real_log[:start + CUTS[cut](end - start)])
    result = replay(tmp_path / "torn.log", MINIMAL, ctx=ctx)
    assert result.frames == REAL_FRAMES - 1 and result.equal, result.mismatches[:3]
    assert (result.damage.kind, result.damage.offset) == (TORN, start)


@pytest.mark.slow
def test_replay_reports_a_torn_tail_and_passes(tmp_path, capsys, real_log):
    start, _ = record_spans(real_log)[-1]
    (tmp_path / "torn.log").write_bytes(real_log[:start + 30])
    code = cli.main(["replay", str(tmp_path / "torn.log"), "--scene", str(MINIMAL),
                     "--out", str(tmp_path / "replay")])
    output = " ".join(capsys.readouterr().out.split())  # rich wraps long lines
    assert code == 0
    assert f"{REAL_FRAMES - 1} frames replayed: every checksum reproduced" in output
    assert f"torn tail at byte {start}: the last 30 bytes are an unfinished record" in output
    summary = json.loads((tmp_path / "replay" / "replay.json").read_text())
    assert summary["equal"] and summary["damage"] == {
        "kind": "torn", "offset": start, "size": 30, "whole_records": REAL_FRAMES - 1}


@pytest.mark.slow
def test_replay_stops_at_a_corrupt_record_and_fails(tmp_path, capsys, real_log):
    data = bytearray(real_log)
    start, _ = record_spans(real_log)[10]
    data[start + 40] ^= 0x01
    (tmp_path / "flipped.log").write_bytes(data)
    code = cli.main(["replay", str(tmp_path / "flipped.log"), "--scene", str(MINIMAL)])
    output = " ".join(capsys.readouterr().out.split())
    assert code == RUN_ERROR
    assert "10 frames replayed: every checksum reproduced" in output
    assert f"corrupt record at byte {start} (its checksum does not match), after 10 " \
           f"whole records" in output
