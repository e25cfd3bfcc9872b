"""A hostile peer on a cluster's session, for the consistency harness and the tests: what an
attacker on the CAVE's network would try, so that every defence is exercised for real.

It captures the cluster's signed traffic (as anyone on the network can read it) and plays
it back; it sends messages of an earlier run of the same keys (the harness made the keys,
so it signs them as that run's master would have); it forges what a member that holds the
session's shared secret can (HMAC-signed frames and commands without the master's
signature, reports of frames never sent); holding a wall's own key, it answers state
queries with forged snapshots (an old frame, one that does not fit the scene, one whose
chunks are not the named state); and it floods the nodes with junk and with state queries.
"""

from __future__ import annotations

import hashlib
import hmac
import itertools
import logging
import threading
import time
from collections import Counter, defaultdict

import numpy as np
import zenoh

from cavesim.core.errors import ClusterError, ProtocolError
from cavesim.core.frame import FrameInput
from cavesim.core.limits import MAX_PARTICLES
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.wire import (
    Command,
    ControlMessage,
    Credentials,
    FrameMessage,
    ReportMessage,
    SessionKeys,
    StateRequest,
    decode_envelope,
    encode,
)
from cavesim.core.wire.envelope import HEADER, SIGNED, Message, new_run_id
from cavesim.core.wire.network import NetworkSettings, open_session
from cavesim.core.wire.payloads.state_transfer import SnapshotChunk, SnapshotHeader

log = logging.getLogger("cavesim.rogue")
FORGERIES = ("old", "misfit", "corrupt")  # the snapshots a forger serves
FORGED_PARTICLES = 64  # particles of a corrupt snapshot: a whole chunk of junk
FLAGS_AT = 6  # the header's flags byte: after the magic, the version and the kind


def member_signed(message: Message, session: str, secret: bytes, run_id: int) -> bytes:
    """`message` with the session's HMAC but not the master's signature: what a node that
    holds the shared secret can make of a frame or a command (every receiver must refuse it)."""
    data = bytearray(encode(message, session, run_id=run_id))
    data[FLAGS_AT] = SIGNED
    return bytes(data) + hmac.new(secret, bytes(data), hashlib.sha256).digest()


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
        self._lock = threading.Lock()
        self._declarations: list = []
        self._forgers: list[zenoh.Session] = []

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
        report = ReportMessage(frame, self.walls[0], "2" * 32, 1, 0, 0, 0)
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
        report = ReportMessage(frame + 1000, self.walls[0], "3" * 32, 1, 0, 0, 0)
        self.put("unsent-frame-report", self.keys.report(self.walls[0]),
                 encode(report, self.name, member, run_id))

    def in_other_walls_names(self, member: Credentials, run_id: int, frame: int) -> None:
        """An insider holding one wall's key (`member`) reports frame `frame` in every other
        wall's name, with a checksum none holds: the master must take none of them (a
        report counts only under the key of the wall it names)."""
        for wall in self.walls:
            if wall != member.member.name:
                report = ReportMessage(frame, wall, "5" * 32, 1, 0, 0, 0)
                self.put("report-in-another-wall's-name", self.keys.report(wall),
                         encode(report, self.name, member, run_id))

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

    # -- forged snapshots ------------------------------------------------------------------

    def serve_forged_snapshots(self, endpoint: str, insiders: list[Credentials],
                               emitters: int) -> None:
        """One forger per kind of FORGERIES, each a peer of its own (a resyncing node
        follows one replier at a time) holding a healthy wall's key in turn (`insiders`),
        answering every wall's state queries: one holding the key of the wall asked is
        refused by what it sends, the others by whose key signed it."""
        for forgery, member in zip(FORGERIES, itertools.cycle(insiders)):
            forger = open_session(NetworkSettings(connect=(endpoint,)))
            self._forgers.append(forger)
            self._declarations.append(forger.declare_queryable(
                self.keys.state(), lambda query, forgery=forgery, member=member: self._forge(
                    query, forgery, member, emitters)))

    def _forge(self, query: zenoh.Query, forgery: str, member: Credentials,
               emitters: int) -> None:
        try:
            envelope = decode_envelope(query.payload.to_bytes(), self.name, member)
        except (ProtocolError, AttributeError):
            query.drop()
            return
        request, run_id = envelope.message, envelope.run_id
        if not isinstance(request, StateRequest):
            query.drop()
            return
        empty = np.zeros(emitters, EMITTER_DTYPE)
        if forgery == "old":
            header = SnapshotHeader(max(request.frame - 10, 0), 1, 0, 1, "4" * 32, empty)
            chunks = []
        elif forgery == "misfit":
            header = SnapshotHeader(request.frame, 1, MAX_PARTICLES, MAX_PARTICLES // 64,
                                    request.digest, empty)  # more than any scene holds
            chunks = []
        else:
            header = SnapshotHeader(request.frame, 1, FORGED_PARTICLES, FORGED_PARTICLES,
                                    request.digest, empty)
            chunks = [SnapshotChunk(request.frame, 0, bytes(FORGED_PARTICLES * PARTICLE_BYTES))]
        try:
            for message in (header, *chunks):
                query.reply(str(query.key_expr), encode(message, self.name, member, run_id))
            with self._lock:
                self.sent[f"{forgery}-snapshot"] += 1
        except zenoh.ZError as e:
            log.info("a forged reply failed: %s", e)
        finally:
            query.drop()

    def close(self) -> None:
        for declaration in reversed(self._declarations):
            declaration.undeclare()
        for forger in self._forgers:
            forger.close()
        self.zenoh.close()
