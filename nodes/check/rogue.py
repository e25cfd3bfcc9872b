"""A hostile peer on a cluster's session, for the consistency harness and the tests: what an
attacker on the CAVE's network would try, so that every defence is exercised for real.

It captures the cluster's signed traffic (as anyone on the network can read it) and plays
it back; it sends messages of an earlier run of the same keys (the harness made the keys,
so it signs them as that run's master would have); it forges what a member that holds the
session's shared secret can (HMAC-signed frames and commands without the master's
signature, reports of frames never sent, reports in other walls' names); it replays the
walls' own state and block queries and an earlier run's tracking messages, starts beside the
master as a second master with the same keys, sends messages larger than the transport
takes, floods the nodes with junk and with state queries, and sends the preview's session
controls with a wall's key. (Insiders that serve forged
states are in nodes/check/state_forgers.py.)
"""

from __future__ import annotations

import hashlib
import hmac
import itertools
import logging
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable
from typing import TypeVar

import numpy as np
import zenoh

from cavesim.core.errors import ClusterError, ProtocolError
from cavesim.core.frame import FrameInput
from cavesim.core.frame_cost import NO_COST
from cavesim.core.wire import (
    Command,
    ControlMessage,
    Credentials,
    FrameMessage,
    HeadState,
    ReportMessage,
    SessionControls,
    SessionKeys,
    StateRequest,
    TrackingMessage,
    WandState,
    decode_envelope,
    encode,
)
from cavesim.core.wire.envelope import HEADER, SIGNED, Message, new_run_id
from cavesim.core.wire.network import MAX_MESSAGE_BYTES, NetworkSettings, open_session

log = logging.getLogger("cavesim.rogue")
T = TypeVar("T")
ANSWER_SECONDS = 10.0  # s a replayed query is open: long enough that every wall takes it
FLAGS_AT = 6  # the header's flags byte: after the magic, the version and the kind
FORGED_HEAD = HeadState((7.0, 7.0, 7.0))  # the pose of the tracking messages it replays
TAKEN_HEAD = HeadState((0.5, -0.5, 1.625))  # of the one fresh message it sends (float32 exact)
FORGED_CONTROLS = {  # a control-forgery's requests (CONTROL_REQUESTS): the levels a
    # preview's session controls have after P, then R, then Esc
    "pause": SessionControls(paused=True),
    "reset": SessionControls(paused=True, resets=1),
    "stop": SessionControls(paused=True, resets=1, quit=True),
}


def member_signed(message: Message, session: str, secret: bytes, run_id: int) -> bytes:
    """`message` with the session's HMAC but not the master's signature: what a node that
    holds the shared secret can make of a frame or a command (every receiver must refuse it)."""
    data = bytearray(encode(message, session, run_id=run_id))
    data[FLAGS_AT] = SIGNED
    return bytes(data) + hmac.new(secret, bytes(data), hashlib.sha256).digest()


def tracked(head: HeadState, sent_ns: int) -> TrackingMessage:
    """A tracking message of `head` with an idle wand, stamped `sent_ns`."""
    return TrackingMessage(0, head, WandState(), sent_ns)


def run_id_of(data: bytes) -> int:
    """The run id in a message's header (in clear: anyone on the network reads it)."""
    return HEADER.unpack_from(data)[6]


class RoguePeer:
    """A zenoh peer connected to the cluster at `endpoint`, on session `session`."""

    def __init__(self, endpoint: str, session: str, walls: tuple[str, ...]) -> None:
        self.name, self.walls = session, walls
        self.keys = SessionKeys(session)
        self.zenoh = open_session(NetworkSettings(connect=(endpoint,)))
        # key kind ("frame", "control", "report") -> (key, bytes) as they were sent
        self.captured: dict[str, list[tuple[str, bytes]]] = defaultdict(list)
        self.sent: Counter[str] = Counter()  # what it sent, by what it was
        self._lock = threading.Condition()  # notified at each message captured, query taken
        self._open_queries = 0  # replayed queries not yet taken by the walls asked
        self._declarations: list = []

    # -- listening -------------------------------------------------------------------------

    def capture(self) -> None:
        """Keep every frame, command and report the cluster sends from now on."""
        for kind, key in (("frame", self.keys.frame), ("control", self.keys.control),
                          ("report", self.keys.report())):
            self._declarations.append(self.zenoh.declare_subscriber(
                key, lambda sample, kind=kind: self._keep(kind, str(sample.key_expr),
                                                          sample.payload.to_bytes()),
                allowed_origin=zenoh.Locality.REMOTE))  # not what it sends itself

    def _keep(self, kind: str, key: str, data: bytes) -> None:
        with self._lock:
            self.captured[kind].append((key, data))
            self._lock.notify_all()

    def captured_count(self, kind: str) -> int:
        with self._lock:
            return len(self.captured[kind])

    def await_captured(self, kind: str, since: int, found: Callable[[bytes], T | None],
                       deadline: float) -> T | None:
        """What `found` makes of the first message of `kind` captured after the first
        `since` of which it makes something (None: none until the monotonic `deadline`)."""
        with self._lock:
            while True:
                for _, data in self.captured[kind][since:]:
                    if (made := found(data)) is not None:
                        return made
                since = len(self.captured[kind])
                left = deadline - time.monotonic()
                if left <= 0 or not self._lock.wait(left):
                    return None

    def capture_queries(self) -> None:
        """Keep every state and block query sent on the session from now on (a queryable of
        its own hears them as the walls' do), answering none."""
        for key in (self.keys.state(), self.keys.blocks()):
            self._declarations.append(self.zenoh.declare_queryable(key, self._keep_query))

    def _keep_query(self, query: zenoh.Query) -> None:
        payload = query.payload
        if payload is not None:
            self._keep("query", str(query.key_expr), payload.to_bytes())
        query.drop()

    def current_run(self) -> int:
        """The run id of the latest frame it captured (0 before any)."""
        with self._lock:
            frames = self.captured["frame"]
            return run_id_of(frames[-1][1]) if frames else 0

    def await_cluster(self, timeout: float = 10.0) -> None:
        """Until this peer sees the master's and every wall's liveliness token (it reaches
        them all; after a master was killed, the new one)."""
        deadline = time.monotonic() + timeout
        liveliness = self.zenoh.liveliness()
        while time.monotonic() < deadline:
            walls = {self.keys.node_of(reply.ok.key_expr)
                     for reply in liveliness.get(self.keys.alive(), timeout=1.0) if reply.ok}
            master = any(reply.ok for reply in liveliness.get(self.keys.master_alive(),
                                                              timeout=1.0))
            if master and walls >= set(self.walls):
                return
        raise ClusterError(f"the rogue peer did not reach the master and the walls within "
                           f"{timeout} s")

    # -- sending ---------------------------------------------------------------------------

    def put(self, what: str, key: str, data: bytes) -> None:
        self.zenoh.put(key, data, congestion_control=zenoh.CongestionControl.BLOCK)
        self.sent[what] += 1

    def replay_captured(self, kind: str, count: int) -> int:
        """Publish the first and the last `count` captured messages of `kind` again,
        verbatim (the first are an earlier run's when a master was replaced since)."""
        with self._lock:
            captured = self.captured[kind]
            old = captured[:count] + captured[max(count, len(captured) - count):]
        for key, data in old:
            self.put(f"replayed-{kind}", key, data)
        return len(old)

    def as_an_earlier_run(self, master: Credentials, frame: int) -> None:
        """A frame, a RESYNC and a STOP as the master of an earlier run with the same keys
        signed them, and a report of that run: each must be refused for its run id."""
        earlier = new_run_id()
        inputs = FrameInput(1 / 60, np.eye(3))
        for what, key, message in (
                ("earlier-run-frame", self.keys.frame, FrameMessage(frame, inputs)),
                ("earlier-run-resync", self.keys.control,
                 ControlMessage(frame, Command.RESYNC, self.walls[-1], self.walls[0],
                                "1" * 32)),
                ("earlier-run-stop", self.keys.control, ControlMessage(frame, Command.STOP))):
            self.put(what, key, encode(message, self.name, master, earlier))
        report = ReportMessage(frame, self.walls[0], "2" * 32, 1, 0, NO_COST)
        self.put("earlier-run-report", self.keys.report(self.walls[0]),
                 encode(report, self.name, master.for_members(), earlier))

    def as_a_member(self, member: Credentials, run_id: int, frame: int) -> None:
        """What an insider holding a wall's key (`member`) could try: a frame and a STOP
        with only the HMAC (no master signature), and that wall's report of a frame the
        master has not sent."""
        inputs = FrameInput(1 / 60, np.eye(3))
        self.put("member-frame", self.keys.frame,
                 member_signed(FrameMessage(frame, inputs), self.name, member.secret, run_id))
        self.put("member-stop", self.keys.control,
                 member_signed(ControlMessage(frame, Command.STOP), self.name, member.secret,
                               run_id))
        report = ReportMessage(frame + 1000, self.walls[0], "3" * 32, 1, 0, NO_COST)
        self.put("unsent-frame-report", self.keys.report(self.walls[0]),
                 encode(report, self.name, member, run_id))

    def in_other_walls_names(self, member: Credentials, run_id: int, frame: int) -> None:
        """An insider holding one wall's key (`member`) reports frame `frame` in every other
        wall's name, with a checksum none holds: the master must take none of them (a
        report counts only under the key of the wall it names)."""
        for wall in self.walls:
            if wall != member.member.name:
                report = ReportMessage(frame, wall, "5" * 32, 1, 0, NO_COST)
                self.put("report-in-another-wall's-name", self.keys.report(wall),
                         encode(report, self.name, member, run_id))

    def replay_queries(self, seconds: float, most: int) -> None:
        """Send the captured state and block queries again, verbatim, round and round, for
        `seconds` or `most` queries (outsiders starving a resync with the walls' own
        queries); and as many queries as a wall of an earlier run signed them."""
        with self._lock:
            captured = list(self.captured["query"])
        if not captured:
            log.warning("no state or block query was captured to replay")
            return
        stop = time.monotonic() + seconds
        for (key, data), _ in zip(itertools.cycle(captured), range(most)):
            if time.monotonic() > stop:
                break
            self._ask(key, data)
            with self._lock:
                self.sent["replayed-query"] += 1

    def earlier_run_queries(self, member: Credentials, count: int) -> None:
        """`count` state queries as the wall `member` signed them in an earlier run."""
        earlier = new_run_id()
        for i in range(count):
            wall = self.walls[(i + 1) % len(self.walls)]
            request = StateRequest(1, wall, "6" * 32, asker=member.member.name)
            self._ask(self.keys.state(wall), encode(request, self.name, member, earlier))
        with self._lock:
            self.sent["earlier-run-query"] += count

    def _ask(self, key: str, payload: bytes) -> None:
        """A query whose answer nobody reads; it is open until every wall asked has taken
        it (answered, refused or dropped) or ANSWER_SECONDS have passed."""
        with self._lock:
            self._open_queries += 1
        self.zenoh.get(key, zenoh.handlers.Callback(lambda reply: None, self._answered),
                       payload=payload, timeout=ANSWER_SECONDS)

    def _answered(self) -> None:
        with self._lock:
            self._open_queries -= 1
            self._lock.notify_all()

    def await_answered(self) -> int:
        """Wait until every query sent by `replay_queries` and `earlier_run_queries` has
        been taken by the walls asked (each counted its refusal before it let go of the
        query), at most ANSWER_SECONDS past the last; how many are still open."""
        with self._lock:
            self._lock.wait_for(lambda: not self._open_queries, ANSWER_SECONDS)
            return self._open_queries

    def replay_tracking(self, tracker: Credentials, run_id: int, count: int) -> None:
        """Tracking messages the master must not take: `count` captured from an earlier run
        (signed by a tracker, sent a minute ago, all of one forged pose, FORGED_HEAD) and
        `count` without a key; then, as a tracker of this run, one fresh message (taken: its
        pose, TAKEN_HEAD, reaches the frames), the same again `count` times, and one sent
        longer ago than the master takes."""
        earlier, now = new_run_id(), time.time_ns()
        for i in range(count):
            old = tracked(FORGED_HEAD, now - 60 * 10**9 + i * 10**7)
            self.put("earlier-run-tracking", self.keys.tracking,
                     encode(old, self.name, tracker, earlier))
            self.put("unsigned-tracking", self.keys.tracking, encode(old, self.name))
        fresh = encode(tracked(TAKEN_HEAD, time.time_ns()), self.name, tracker, run_id)
        self.put("fresh-tracking", self.keys.tracking, fresh)
        for _ in range(count):
            self.put("replayed-tracking", self.keys.tracking, fresh)
        stale = tracked(FORGED_HEAD, time.time_ns() - 10 * 10**9)
        self.put("stale-tracking", self.keys.tracking,
                 encode(stale, self.name, tracker, run_id))

    def controls_as_a_wall(self, member: Credentials, run_id: int, request: str) -> int:
        """The session controls of `request` (one of CONTROL_REQUESTS), fresh, of this run and
        signed with a wall's own key (`member`), as the preview's window would send them: the
        master must refuse them, as no operator's. Their send time (ns)."""
        asks = TrackingMessage(0, HeadState(), WandState(), time.time_ns(), False,
                               FORGED_CONTROLS[request])
        self.put(f"forged-{request}", self.keys.tracking,
                 encode(asks, self.name, member, run_id))
        return asks.sent_ns

    def frames_with_head(self, head: HeadState, member: Credentials, run_id: int) -> int:
        """How many captured frames of run `run_id` carry `head` (checked as a wall would
        check them)."""
        with self._lock:
            frames = [data for _, data in self.captured["frame"] if run_id_of(data) == run_id]
        carrying = 0
        for data in frames:
            try:
                message = decode_envelope(data, self.name, member).message
            except ProtocolError:
                continue
            carrying += isinstance(message, FrameMessage) and message.head == head
        return carrying

    def as_a_second_master(self, master: Credentials, frame: int, count: int) -> None:
        """A second master with the session's keys, started beside the first without seeing
        it: its liveliness token for a run of its own, and `count` frames it signs for that
        run, from frame `frame` on."""
        second = new_run_id()
        token = self.zenoh.liveliness().declare_token(self.keys.master_alive(second))
        try:
            time.sleep(0.2)  # the walls learn of its token before its frames come
            inputs = FrameInput(1 / 60, np.eye(3))
            for k in range(frame, frame + count):
                self.put("second-master-frame", self.keys.frame,
                         encode(FrameMessage(k, inputs), self.name, master, second))
            time.sleep(0.2)
        finally:
            token.undeclare()

    def oversize(self, count: int, size: int, under_limit: int, queries: int) -> None:
        """`count` messages of `size` bytes on the frame, control, report and tracking keys
        in turn and `queries` state queries as large (the transport must drop them all
        before they are buffered); `under_limit` junk frames just under the transport's
        limit (which reach the nodes, and are counted)."""
        junk = bytes(size)
        keys = (self.keys.frame, self.keys.control, self.keys.report(self.walls[0]),
                self.keys.tracking)
        for i in range(count):
            self.put("oversize-message", keys[i % len(keys)], junk)
        for i in range(queries):
            self.zenoh.get(self.keys.state(self.walls[i % len(self.walls)]), lambda reply: None,
                           payload=junk, timeout=0.5)
        self.sent["oversize-query"] += queries
        for _ in range(under_limit):
            self.put("junk-under-the-limit", self.keys.frame, bytes(MAX_MESSAGE_BYTES - 2**16))

    def flood(self, messages: int, queries: int, size: int = 200) -> float:
        """`messages` junk messages on the frame and control keys and `queries` state
        queries without the key, as fast as zenoh takes them; the seconds it took."""
        started = time.monotonic()
        junk = (bytes(range(256)) * (size // 256 + 1))[:size]
        frame = self.zenoh.declare_publisher(self.keys.frame,
                                             congestion_control=zenoh.CongestionControl.BLOCK)
        control = self.zenoh.declare_publisher(self.keys.control,
                                               congestion_control=zenoh.CongestionControl.BLOCK)
        for i in range(messages):
            (frame if i % 2 else control).put(junk)
        for i in range(queries):
            self.zenoh.get(self.keys.state(self.walls[i % len(self.walls)]), lambda reply: None,
                           payload=junk, timeout=0.5)
        frame.undeclare()
        control.undeclare()
        self.sent["junk"] += messages
        self.sent["unsigned-state-query"] += queries
        return time.monotonic() - started

    def close(self) -> None:
        for declaration in reversed(self._declarations):
            declaration.undeclare()
        self.zenoh.close()
