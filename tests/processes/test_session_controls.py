"""Session controls in a run with keys, over the wire to a real node: a wall's key asking
to stop is refused and counted and the run goes on; an operator's pause, resume and stop
act on the frame they were sent before, and report.json names the operator for each.

Each request is sent just before a frame is made, and that frame waits until the master's
link has taken or refused it: the order is the test's, not the network's."""

from __future__ import annotations

import os
import time
from pathlib import Path

from cavesim.core.wire import HeadState, SessionControls, TrackingMessage, WandState, encode
from cavesim.core.wire.credentials import OPERATOR, WALL, generate
from nodes.check.rogue import RoguePeer
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.master.process import MasterConfig

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WAIT = 10.0  # s at most for the master's link to take or refuse a request


def test_a_walls_stop_is_refused_and_an_operators_controls_are_taken_with_their_sender(
        tmp_path):
    master = generate()
    wall, operator = master.issue(WALL, "front"), master.issue(OPERATOR, "desk")
    config = MasterConfig(("front",), MINIMAL, 60, f"ctl{os.getpid()}", credentials=master)
    links, peers = [], []
    requests = {  # frame -> (whose key, the controls it sends)
        5: (wall, SessionControls(quit=True)),
        10: (operator, SessionControls(paused=True)),
        15: (operator, SessionControls()),
        20: (operator, SessionControls(quit=True)),
    }

    def send(cluster, k):
        if k == 1:
            peers.append(RoguePeer(cluster.master_endpoint, cluster.session, ("front",)))
            peers[0].await_cluster()
        if k not in requests:
            return
        (link,), (peer,) = links, peers
        key, controls = requests[k]
        refused = link.rejects.counts.get("not-an-operator", 0)
        asks = TrackingMessage(0, HeadState(), WandState(), time.time_ns(), False, controls)
        peer.put("controls", peer.keys.tracking, encode(asks, config.session, key, link.run_id))
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not (
                link.rejects.counts.get("not-an-operator", 0) > refused
                or link.controller is not None and link.controller.message.sent_ns == asks.sent_ns):
            time.sleep(0.005)

    try:
        record = run_cluster(ClusterPlan(config, tmp_path), before_frame=send,
                             on_link=links.append)
    finally:
        for peer in peers:
            peer.close()
    summary = record.summary()
    assert summary["rejected_messages"]["master"]["not-an-operator"] == 1  # the wall's stop
    assert summary["user_actions"] == [
        {"frame": 10, "action": "pause", "by": "operator desk"},
        {"frame": 15, "action": "resume", "by": "operator desk"},
        {"frame": 20, "action": "stop", "by": "operator desk"}]
    assert record.user_stopped and record.frames == 19 and record.paused_frames == 5
    assert record.final.agree and record.final.all_walls_in
