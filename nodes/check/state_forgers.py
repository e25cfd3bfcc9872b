"""Insiders that answer a resyncing node's state query with a state it must not load, for
the consistency harness: each a zenoh peer of its own (a resyncing node follows one replier
at a time) holding one wall's own key.

The forgers of `serve_forgeries` send an old snapshot, one that does not fit the scene, and
one whose chunks are not the named state. The forgers of `serve_collisions` send a state
whose checksum *is* the named one (nodes/check/checksum_collision.py): each watches the
walls' reports, fetches the state of the wall named to confirm the resync (neither the
victim nor its source) under its own key as soon as that wall reports it, and makes its
colliding twin; it answers the victim's query with it once it is ready. The source
withholds its answer to that first query (`withhold`, nodes/faults.py), so the twin is
judged every time: under another wall's key it is refused by its signer; as the source
itself (its key) only the confirmation by a second wall refuses it.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections import Counter

import numpy as np
import zenoh

from cavesim.core.digest.twin import reference_checksum
from cavesim.core.errors import ProtocolError
from cavesim.core.limits import MAX_PARTICLES
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.wire import (
    Credentials,
    ReportMessage,
    SessionKeys,
    StateRequest,
    decode_envelope,
    encode,
)
from cavesim.core.wire.credentials import WALL
from cavesim.core.wire.network import NetworkSettings, open_session
from cavesim.core.wire.payloads.state_transfer import (
    MAX_CHUNK_PARTICLES,
    SnapshotChunk,
    SnapshotHeader,
)
from cavesim.core.wire.replies import asking
from nodes.check.checksum_collision import changed_particles, colliding_particles

log = logging.getLogger("cavesim.rogue")
FORGERIES = ("old", "misfit", "corrupt")  # the snapshots `serve_forgeries` sends
FORGED_PARTICLES = 64  # particles of a corrupt snapshot: a whole chunk of junk
FETCH_SECONDS = 5.0  # how long a collision forger waits for the state it fetches
COLLIDING, COLLIDING_SOURCE = "colliding-snapshot", "colliding-source-snapshot"  # served
# under another wall's key, and as the source (its own key)
Snapshot = tuple[SnapshotHeader, list[SnapshotChunk]]


class StateForgers:
    """Forgers on session `session`, connected at `endpoint`; `sent` counts what they sent,
    by what it was; `collisions` says, per colliding state made, the checksum named and the
    colliding state's own (as the twin computes it), and which particles differ."""

    def __init__(self, endpoint: str, session: str, walls: tuple[str, ...]) -> None:
        self.endpoint, self.name, self.walls = endpoint, session, walls
        self.keys = SessionKeys(session)
        self.sent: Counter[str] = Counter()
        self.twins_sent: Counter[tuple[str, int]] = Counter()  # (what, frame) -> times
        self._lock = threading.Lock()
        self.collisions: list[dict] = []
        # a peer per forger, opened now: by the time they forge, zenoh's gossip has linked
        # each to every wall directly (a late peer's replies would go through the master's)
        self._peers = [open_session(NetworkSettings(connect=(endpoint,)))
                       for _ in range(len(FORGERIES))]
        self._idle = list(self._peers)
        self._declarations: list = []
        # (forger's wall, frame, digest) -> the colliding twin of that state, signed by that
        # forger (None while it is made)
        self._twins: dict[tuple[str, int, str], list[bytes] | None] = {}
        self._ready = threading.Condition(self._lock)

    def _count(self, what: str, frame: int | None) -> None:
        with self._lock:
            self.sent[what] += 1
            if frame is not None:
                self.twins_sent[what, frame] += 1

    def _peer(self) -> zenoh.Session:
        """A forger's own peer: one opened at the start while there are (else a new one)."""
        if self._idle:
            return self._idle.pop()
        session = open_session(NetworkSettings(connect=(self.endpoint,)))
        self._peers.append(session)
        return session

    # -- old, misfit and corrupt snapshots ---------------------------------------------------

    def serve_forgeries(self, insiders: list[Credentials], emitters: int,
                        frames: range) -> None:
        """One forger per kind of FORGERIES, holding the keys of `insiders` in turn,
        answering every wall's state queries for states of `frames`: one holding the key of
        the wall asked is refused by what it sends, the others by whose key signed it."""
        for forgery, member in zip(FORGERIES, itertools.cycle(insiders)):
            self._declarations.append(self._peer().declare_queryable(
                self.keys.state(), lambda query, forgery=forgery, member=member: self._forge(
                    query, forgery, member, emitters, frames)))

    def _forge(self, query: zenoh.Query, forgery: str, member: Credentials,
               emitters: int, frames: range) -> None:
        opened = self._request(query, member)
        if opened is None:
            return
        request, run_id = opened
        if request.frame not in frames:
            query.drop()
            return
        empty = np.zeros(emitters, EMITTER_DTYPE)
        if forgery == "old":
            header = SnapshotHeader(max(request.frame - 10, 0), 1, 0, 1, "4" * 32, empty)
            chunks = []
        elif forgery == "misfit":
            header = SnapshotHeader(request.frame, 1, MAX_PARTICLES, MAX_CHUNK_PARTICLES,
                                    request.digest, empty)  # more than any scene holds
            chunks = []
        else:
            header = SnapshotHeader(request.frame, 1, FORGED_PARTICLES, FORGED_PARTICLES,
                                    request.digest, empty)
            chunks = [SnapshotChunk(request.frame, 0, bytes(FORGED_PARTICLES * PARTICLE_BYTES))]
        self._reply(query, (header, chunks), member, run_id, f"{forgery}-snapshot")

    # -- states that collide with the named checksum -------------------------------------

    def serve_collisions(self, insiders: list[Credentials], victim: str,
                         frames: tuple[int, ...], fetch_from: str, as_source: bool) -> None:
        """A forger per insider, against the wall `victim`, which diverges at `frames` (the
        insiders made it): on `fetch_from`'s report of such a frame, it fetches that state
        and makes its colliding twin; it then answers the victim's query with it, signed by
        its own key: a query for another wall's state, or, `as_source`, for its own wall's
        (the resync's source itself an insider)."""
        for member in insiders:
            peer = self._peer()
            self._declarations += [
                peer.declare_subscriber(self.keys.report(), lambda sample, member=member,
                                        peer=peer: self._on_report(sample, member, peer,
                                                                   fetch_from, frames)),
                peer.declare_queryable(self.keys.state(), lambda query, member=member:
                                       self._answer_with_twin(query, member, victim, frames,
                                                              as_source))]

    def _on_report(self, sample: zenoh.Sample, member: Credentials, peer: zenoh.Session,
                   fetch_from: str, frames: tuple[int, ...]) -> None:
        try:
            envelope = decode_envelope(sample.payload.to_bytes(), self.name, member)
        except ProtocolError:
            return
        report = envelope.message
        if not isinstance(report, ReportMessage) or report.frame not in frames \
                or report.node != fetch_from:
            return
        twin = (member.member.name, report.frame, report.digest)
        with self._lock:
            if any(key[:2] == twin[:2] for key in self._twins):
                return  # one twin of a frame per forger
            self._twins[twin] = None  # being made
        threading.Thread(target=self._make_twin, daemon=True, name="collision forger",
                         args=(peer, member, envelope.run_id,
                               StateRequest(report.frame, report.node, report.digest,
                                            asker=member.member.name))).start()

    def _make_twin(self, peer: zenoh.Session, member: Credentials, run_id: int,
                   request: StateRequest) -> None:
        """Fetch the state `request` names under the forger's own key; keep its twin, signed
        and ready to send (so that it goes out before the wall asked has read its state)."""
        genuine = self._fetch(peer, member, run_id, request)
        if genuine is None:
            log.info("the collision forger got no state of frame %d from %s", request.frame,
                     request.node)
            return
        header, chunks = genuine
        words = np.frombuffer(b"".join(c.data for c in chunks), np.uint32)
        emitter_words = header.emitters.view(np.uint32)
        try:
            twin = colliding_particles(words)
        except ValueError as e:
            log.info("no colliding state of frame %d: %s", request.frame, e)
            return
        size = header.chunk_particles * PARTICLE_BYTES
        data = twin.tobytes()
        replies = [encode(message, self.name, member, run_id) for message in (
            header, *(SnapshotChunk(header.frame, i, data[i * size:(i + 1) * size])
                      for i in range(header.chunks)))]
        with self._ready:
            self._twins[(member.member.name, request.frame, request.digest)] = replies
            log.info("%s's twin of %s's state of frame %d is ready", member.member.name,
                     request.node, request.frame)
            self.collisions.append({
                "frame": request.frame, "fetched_from": request.node,
                "named_checksum": request.digest,
                "genuine_checksum": reference_checksum(words, emitter_words, header.seed).digest,
                "colliding_checksum": reference_checksum(twin, emitter_words,
                                                         header.seed).digest,
                "particles_changed": changed_particles(words, twin)})
            self._ready.notify_all()

    def _fetch(self, peer: zenoh.Session, member: Credentials, run_id: int,
               request: StateRequest) -> Snapshot | None:
        header, chunks = None, []
        deadline = time.monotonic() + FETCH_SECONDS
        with asking(peer, self.keys.state(request.node), deadline,
                    MAX_PARTICLES * PARTICLE_BYTES,
                    payload=encode(request, self.name, member, run_id),
                    consolidation=zenoh.ConsolidationMode.NONE) as replies:
            for reply in replies:
                if reply.ok is None:
                    continue
                try:
                    envelope = decode_envelope(reply.ok.payload.to_bytes(), self.name, member)
                    envelope.check_signer(WALL, request.node)  # not another forger's twin
                except ProtocolError:
                    continue
                message = envelope.message
                if isinstance(message, SnapshotHeader):
                    header = message
                elif isinstance(message, SnapshotChunk) and header is not None:
                    chunks.append(message)
                if header is not None and len(chunks) == header.chunks:
                    return header, sorted(chunks, key=lambda c: c.index)
        return None

    def _answer_with_twin(self, query: zenoh.Query, member: Credentials, victim: str,
                          frames: tuple[int, ...], as_source: bool) -> None:
        """Answer the victim's query at once when the twin is ready (else from a thread,
        once it is)."""
        opened = self._request(query, member)
        if opened is None:
            return
        request, _ = opened
        if request.asker != victim or request.frame not in frames \
                or (request.node == member.member.name) != as_source:
            query.drop()  # not the victim's resync, or not the wall this forger speaks for
            return
        twin = (member.member.name, request.frame, request.digest)
        with self._lock:
            replies = self._twins.get(twin)
        log.info("%s got %s's query for %s's state of frame %d (twin %s)", member.member.name,
                 request.asker, request.node, request.frame,
                 "ready" if replies else "not ready")
        what = COLLIDING_SOURCE if as_source else COLLIDING
        if replies is not None:
            self._send(query, replies, what, request.frame)
        else:
            threading.Thread(target=self._send_when_ready, daemon=True, name="collision forger",
                             args=(query, twin, what)).start()

    def _send_when_ready(self, query: zenoh.Query, key: tuple[str, int, str], what: str
                         ) -> None:
        with self._ready:
            self._ready.wait_for(lambda: self._twins.get(key) is not None, FETCH_SECONDS)
            replies = self._twins.get(key)
        if replies is None:
            log.info("no twin of frame %d was made in %.0f s", key[1], FETCH_SECONDS)
            query.drop()
        else:
            self._send(query, replies, what, key[1])

    # -- both ----------------------------------------------------------------------------

    def _request(self, query: zenoh.Query, member: Credentials
                 ) -> tuple[StateRequest, int] | None:
        """The query's state request and run id (None: the query is dropped)."""
        try:
            envelope = decode_envelope(query.payload.to_bytes(), self.name, member)
        except (ProtocolError, AttributeError):
            envelope = None
        if envelope is None or not isinstance(envelope.message, StateRequest):
            query.drop()
            return None
        return envelope.message, envelope.run_id

    def _reply(self, query: zenoh.Query, snapshot: Snapshot, member: Credentials,
               run_id: int, what: str) -> None:
        header, chunks = snapshot
        self._send(query, [encode(message, self.name, member, run_id)
                           for message in (header, *chunks)], what)

    def _send(self, query: zenoh.Query, replies: list[bytes], what: str,
              twin_of: int | None = None) -> None:
        """Send `replies` (`twin_of`: the frame, when they are a colliding twin)."""
        try:
            for data in replies:
                query.reply(str(query.key_expr), data)
            self._count(what, twin_of)
        except zenoh.ZError as e:
            log.info("a forged reply failed: %s", e)
        finally:
            query.drop()

    def close(self) -> None:
        for declaration in reversed(self._declarations):
            declaration.undeclare()
        for session in self._peers:
            session.close()
