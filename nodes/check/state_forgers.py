"""Insiders that answer a resyncing node's state query with a state it must not load, for
the consistency harness: each a zenoh peer of its own (a resyncing node follows one replier
at a time) holding one wall's own key.

The forgers of `serve_forgeries` send an old snapshot, one that does not fit the scene, and
one whose chunks are not the named state. The forgers of `serve_collisions` send a state
whose checksum *is* the named one (nodes/check/checksum_collision.py): on the diverged
node's query, each fetches that state under its own key from the wall named to confirm the
resync (neither the node nor its source), makes its colliding twin and answers with it. The
source withholds its answer to that first query (`withhold`, nodes/faults.py), so the twin
is judged every time: under another wall's key it is refused by its signer; as the source
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
        # forger (None: none could be made)
        self._twins: dict[tuple[str, int, str], list[bytes] | None] = {}
        self._making = threading.Lock()  # one twin at a time

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
        harness makes it): when the victim asks for a state of such a frame (another wall's,
        or, `as_source`, the forger's own wall's: the resync's source itself an insider), it
        fetches that state from `fetch_from` under its own key (the wall holds it while the
        master waits for the resync), makes its colliding twin once, and answers with it,
        signed by its own key. Declared at the run's start, long before those frames."""
        for member in insiders:
            peer = self._peer()
            self._declarations.append(peer.declare_queryable(
                self.keys.state(), lambda query, member=member, peer=peer: self._answer_with_twin(
                    query, member, peer, victim, frames, fetch_from, as_source)))

    def _answer_with_twin(self, query: zenoh.Query, member: Credentials, peer: zenoh.Session,
                          victim: str, frames: tuple[int, ...], fetch_from: str,
                          as_source: bool) -> None:
        """Answer the victim's query with the twin, from a thread (it fetches first)."""
        opened = self._request(query, member)
        if opened is None:
            return
        request, run_id = opened
        if request.asker != victim or request.frame not in frames \
                or (request.node == member.member.name) != as_source:
            query.drop()  # not the victim's resync, or not the wall this forger speaks for
            return
        log.info("%s got %s's query for %s's state of frame %d", member.member.name,
                 request.asker, request.node, request.frame)
        genuine = StateRequest(request.frame, fetch_from, request.digest,
                               asker=member.member.name)
        threading.Thread(target=self._send_twin, daemon=True, name="collision forger", args=(
            query, peer, member, run_id, genuine,
            COLLIDING_SOURCE if as_source else COLLIDING)).start()

    def _send_twin(self, query: zenoh.Query, peer: zenoh.Session, member: Credentials,
                   run_id: int, genuine: StateRequest, what: str) -> None:
        """Answer `query` with the twin of the state `genuine` asks for (made once)."""
        with self._making:
            key = (member.member.name, genuine.frame, genuine.digest)
            if key not in self._twins:
                self._twins[key] = self._make_twin(peer, member, run_id, genuine)
            replies = self._twins[key]
        if replies is None:
            query.drop()
        else:
            self._send(query, replies, what, genuine.frame)

    def _make_twin(self, peer: zenoh.Session, member: Credentials, run_id: int,
                   request: StateRequest) -> list[bytes] | None:
        """Fetch the state `request` names under the forger's own key; its twin, signed and
        ready to send (None: none could be made, said in the log)."""
        genuine = self._fetch(peer, member, run_id, request)
        if genuine is None:
            log.info("the collision forger got no state of frame %d from %s", request.frame,
                     request.node)
            return None
        header, chunks = genuine
        words = np.frombuffer(b"".join(c.data for c in chunks), np.uint32)
        emitter_words = header.emitters.view(np.uint32)
        try:
            twin = colliding_particles(words)
        except ValueError as e:
            log.info("no colliding state of frame %d: %s", request.frame, e)
            return None
        size = header.chunk_particles * PARTICLE_BYTES
        data = twin.tobytes()
        log.info("%s's twin of %s's state of frame %d is made", member.member.name,
                 request.node, request.frame)
        with self._lock:
            self.collisions.append({
                "frame": request.frame, "fetched_from": request.node,
                "named_checksum": request.digest,
                "genuine_checksum": reference_checksum(words, emitter_words, header.seed).digest,
                "colliding_checksum": reference_checksum(twin, emitter_words,
                                                         header.seed).digest,
                "particles_changed": changed_particles(words, twin)})
        return [encode(message, self.name, member, run_id) for message in (
            header, *(SnapshotChunk(header.frame, i, data[i * size:(i + 1) * size])
                      for i in range(header.chunks)))]

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
