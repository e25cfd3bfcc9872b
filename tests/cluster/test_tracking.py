"""A tracker's head pose reaches every frame the master sends after it (tracked, not
scripted), and a tracker speaking nonsense is rejected and counted. Like `cavesim tracker`,
the stand-in tracker learns the run id from the master's frames and stamps each message
with its send time."""

import json
import os
import time
from pathlib import Path

import pytest
import zenoh
from master_process import spawn_master

from cavesim.core.framelog import read_frame_log
from cavesim.core.wire import HeadState, SessionKeys, TrackingMessage, WandState, encode
from cavesim.core.wire.envelope import HEADER
from cavesim.core.wire.network import NetworkSettings, zenoh_config
from nodes.launch.launcher import LocalCluster, free_port

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
TRACKED = HeadState((0.5, -0.25, 1.5), (0.0, 0.0, 0.0, 1.0))


@pytest.mark.slow
def test_tracked_head_and_wand_travel_in_the_frames(tmp_path):
    session = f"track{os.getpid()}"
    tracker_endpoint = f"tcp/127.0.0.1:{free_port()}"
    network = NetworkSettings(listen=(tracker_endpoint,))
    with LocalCluster(MINIMAL, tmp_path, session) as cluster, \
            zenoh.open(zenoh_config(network)) as tracker:
        cluster.start_node("front")  # the master connects to the tracker as it starts
        master = spawn_master(cluster, ("front",), 300, ("--connect", tracker_endpoint))
        runs = []  # the run id of the master's frames, as a tracker reads it
        frames = tracker.declare_subscriber(
            SessionKeys(session).frame,
            lambda sample: runs.append(HEADER.unpack_from(sample.payload.to_bytes())[6]))
        for count, line in enumerate(master.stdout):
            if count >= 50 and runs:  # the first 50 frames go out scripted
                tracking = TrackingMessage(count, TRACKED, WandState(buttons=3), time.time_ns())
                tracker.put(SessionKeys(session).tracking,
                            encode(tracking, session, run_id=runs[-1]))
                tracker.put(SessionKeys(session).tracking, b"not a message")
            assert json.loads(line)["frame"] == count + 1
        assert master.wait(timeout=60) == 0
        frames.undeclare()
    _, frames = read_frame_log(tmp_path / "frames.log")
    heads = [(f.message.head.position, f.message.wand.buttons) for f in frames]
    assert heads[0][0][2] == pytest.approx(1.7) and heads[0][1] == 0, "scripted at first"
    assert heads[-1] == (pytest.approx(TRACKED.position), 3), "tracked at the end"
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["rejected_messages"]["master"]["truncated"] > 0  # the 13-byte nonsense
