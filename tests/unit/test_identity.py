"""Every wall speaks only for itself: a report, a snapshot, a block reply or a tracking
message counts only under the key of the member it speaks for, and a state is taken only
from the wall asked.

The master's link is fed messages directly (its zenoh session only listens on loopback);
a resyncing node's fetch is fed replies by a stand-in session and a stand-in GPU state
whose checksum takes any bytes: a state that collides with the named checksum, built so
by construction.
"""

from __future__ import annotations

import os
import time
from types import SimpleNamespace

import numpy as np
import pytest
from zenoh_doubles import RepliesSession, Reply

from cavesim.core.frame_cost import NO_COST
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.wire import (
    BlockQuery,
    BlockReply,
    BlockRequest,
    HeadState,
    ReportMessage,
    SessionControls,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
    TrackingMessage,
    WandState,
    encode,
)
from cavesim.core.wire.credentials import Identity, generate
from cavesim.core.wire.network import NetworkSettings, open_session
from cavesim.core.wire.rejects import RejectCounter
from nodes.blocks import BlockAsker
from nodes.master.link import ZenohMasterLink
from nodes.master.user_requests import Controller
from nodes.wall.snapshots import fetch_snapshot

SESSION = f"id{os.getpid()}"
WALLS = ("front", "left", "right")
RUN = 0x1234
MASTER = generate()
KEYS = {wall: MASTER.issue("wall", wall) for wall in WALLS}
TRACKER = MASTER.issue("tracker", "dtrack")
OPERATOR = MASTER.issue("operator", "desk")
DIGEST = "ab" * 16


def sample(key: str, data: bytes) -> SimpleNamespace:
    return SimpleNamespace(key_expr=key, payload=SimpleNamespace(to_bytes=lambda: data))


@pytest.fixture(scope="module")
def link():
    with open_session(NetworkSettings(listen=("tcp/127.0.0.1:0",))) as session:
        link = ZenohMasterLink(session, SESSION, MASTER, WALLS, RUN)
        link.last_sent = 10
        yield link
        link.close()


def taken(link) -> list:
    events = []
    while not link.events.empty():
        events.append(link.events.get_nowait())
    return events


def report(wall: str, frame: int = 5) -> ReportMessage:
    return ReportMessage(frame, wall, DIGEST, 10, 1, NO_COST)


def test_a_report_counts_only_under_its_own_walls_key(link):
    forged = encode(report("right"), SESSION, KEYS["left"], RUN)  # an insider with left's key
    link._on_report(sample(f"cavesim/{SESSION}/report/right", forged))
    assert taken(link) == [] and link.rejects.counts["wrong-signer"] == 1
    unattributed = encode(report("right"), SESSION, MASTER.for_members(), RUN)  # HMAC alone
    link._on_report(sample(f"cavesim/{SESSION}/report/right", unattributed))
    assert taken(link) == [] and link.rejects.counts["wrong-signer"] == 2
    own = encode(report("right"), SESSION, KEYS["right"], RUN)
    link._on_report(sample(f"cavesim/{SESSION}/report/right", own))
    assert [event.report.node for event in taken(link)] == ["right"]


def tracking(sent_ns: int) -> TrackingMessage:
    return TrackingMessage(0, HeadState((1.0, 2.0, 1.5)), WandState(buttons=3), sent_ns)


def test_tracking_is_taken_only_fresh_of_this_run_from_a_tracker(link):
    key = f"cavesim/{SESSION}/tracking"
    now = time.time_ns()
    attempts = [  # (the sealed message, the reason it is refused)
        (encode(tracking(now), SESSION, TRACKER, 0x999), "wrong-run"),  # another run's
        (encode(tracking(now - 10**10), SESSION, TRACKER, RUN), "stale-tracking"),  # 10 s old
        (encode(tracking(now), SESSION, MASTER.for_members(), RUN), "wrong-signer"),
    ]
    for data, reason in attempts:
        before = link.rejects.counts.get(reason, 0)
        link._on_tracking(sample(key, data))
        assert link.tracking is None and link.rejects.counts[reason] == before + 1
    fresh = encode(tracking(now), SESSION, TRACKER, RUN)
    link._on_tracking(sample(key, fresh))
    assert link.tracking == tracking(now)
    link.tracking = None
    link._on_tracking(sample(key, fresh))  # the same message again: a replay
    assert link.tracking is None and link.rejects.counts["replayed-tracking"] == 1


def test_session_controls_count_only_from_an_operator_and_a_message_without_a_pose_keeps_the_last(
        link):
    """Only an operator's key (a preview window's) may pause, reset and stop: a wall's or a
    tracker's message with controls is refused whole (`not-an-operator`, counted), its pose
    too. The preview's controls before anyone flew carry no pose: the tracker's pose stays,
    and the controls taken name their sender."""
    key, now = f"cavesim/{SESSION}/tracking", time.time_ns()
    posed = tracking(now)
    link._on_tracking(sample(key, encode(posed, SESSION, TRACKER, RUN)))
    before = link.rejects.counts.get("not-an-operator", 0)
    for sender, sent_ns in ((TRACKER, now + 1), (KEYS["front"], now + 2)):
        stop = TrackingMessage(0, HeadState((7.0, 7.0, 7.0)), WandState(), sent_ns, True,
                               SessionControls(paused=True, resets=1, quit=True))
        link._on_tracking(sample(key, encode(stop, SESSION, sender, RUN)))
    assert link.rejects.counts["not-an-operator"] == before + 2
    assert link.controller is None and link.tracking == posed
    asks = TrackingMessage(0, posed.head, WandState(), now + 3, False,
                           SessionControls(paused=True))
    link._on_tracking(sample(key, encode(asks, SESSION, OPERATOR, RUN)))
    assert link.controller == Controller(asks, Identity("operator", "desk"))
    assert link.tracking == posed


def test_tracking_from_a_walls_key_is_refused_and_an_operators_pose_is_taken(link):
    """A wall's key sends no tracking at all (the preview signs as an operator); an
    operator's pose moves the head as a tracker's does."""
    key, now = f"cavesim/{SESSION}/tracking", time.time_ns()
    link.tracking = None
    before = link.rejects.counts.get("wrong-signer", 0)
    link._on_tracking(sample(key, encode(tracking(now), SESSION, KEYS["left"], RUN)))
    assert link.tracking is None and link.rejects.counts["wrong-signer"] == before + 1
    link._on_tracking(sample(key, encode(tracking(now), SESSION, OPERATOR, RUN)))
    assert link.tracking == tracking(now)


# -- a state whose checksum collides with the named one --------------------------------------

class CollidingState:
    """A node's GPU state stand-in whose checksum accepts whatever bytes are staged, as a
    state built to collide with the named checksum would: only who sent it can tell."""

    capacity, emitters = 64, np.zeros(1, EMITTER_DTYPE)

    def __init__(self) -> None:
        self.staged: dict[int, bytes] = {}
        self.committed: bytes | None = None

    def begin_load(self, particles: int) -> None:
        self.staged.clear()

    def write_particle_chunk(self, first: int, data: bytes) -> None:
        self.staged[first] = data

    def commit_load(self, emitters, seed: int, digest: str) -> None:
        self.committed = b"".join(self.staged[k] for k in sorted(self.staged))


def snapshot_signed_by(wall: str, data: bytes) -> list[bytes]:
    header = SnapshotHeader(7, 1, len(data) // PARTICLE_BYTES, 64, DIGEST,
                            np.zeros(1, EMITTER_DTYPE))
    return [encode(m, SESSION, KEYS[wall], RUN)
            for m in (header, SnapshotChunk(7, 0, data))]


def fetch_from_left(replies: list[bytes], state: CollidingState, rejects: RejectCounter):
    from cavesim.core.wire import decode_envelope

    def open_reply(data: bytes):
        return decode_envelope(data, SESSION, KEYS["front"])

    session = RepliesSession([Reply("rogue", data) for data in replies])
    return fetch_snapshot(session, f"cavesim/{SESSION}/state/left", state,
                          b"", open_reply, StateRequest(7, "left", DIGEST),
                          time.monotonic() + 30, rejects, set())


def test_a_colliding_state_from_anyone_but_the_wall_asked_is_refused_unstaged():
    colliding = bytes(range(256)) * 5  # 32 records of any bytes
    state, rejects = CollidingState(), RejectCounter("front")
    assert fetch_from_left(snapshot_signed_by("right", colliding), state, rejects) is None
    assert rejects.counts == {"wrong-signer": 1}
    assert state.staged == {} and state.committed is None
    header = fetch_from_left(snapshot_signed_by("left", colliding), state, rejects)
    assert header is not None and state.committed == colliding  # the wall asked: taken


def test_a_block_reply_counts_only_from_the_wall_asked():
    """A resyncing node's delta takes records only from the wall it asked: the same reply
    signed by another wall's key is refused (`wrong-signer`) and its replier not heard
    again; the asked wall's is taken."""
    from cavesim.core.wire import decode_envelope

    request = BlockRequest(7, "left", DIGEST, BlockQuery.RECORDS, 0, (3,), asker="front")
    records = BlockReply(7, "left", BlockQuery.RECORDS, 0, 1, 64, 1, bytes(PARTICLE_BYTES))
    session = RepliesSession([Reply("rogue", encode(records, SESSION, KEYS["right"], RUN)),
                              Reply("left", encode(records, SESSION, KEYS["left"], RUN))])
    rejects = RejectCounter("front")
    asker = BlockAsker(session, f"cavesim/{SESSION}/blocks/left", lambda message: b"",
                       lambda data: decode_envelope(data, SESSION, KEYS["front"]), rejects)
    assert asker(request) == records
    assert rejects.counts == {"wrong-signer": 1} and asker.failed == {"rogue"}
