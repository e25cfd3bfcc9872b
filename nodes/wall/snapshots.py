"""Snapshots between wall nodes over zenoh: a state query answered by a stream of replies.

`send_snapshot` answers one `state/<wall>` query with a header and the chunks, reading each
chunk from the GPU just before sending it; `fetch_snapshot` asks for one and streams the
chunks straight into the receiver's back particle buffer (`SnapshotLoad`), committing only
a whole, verified state. Every wait has a deadline (wire/snapshot.py: `transfer_seconds`),
and the replies are read as wire/replies.py hands them over, never blocking zenoh.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable

import zenoh

from cavesim.core.digest.records_digest import RecordsDigest, records_digest
from cavesim.core.digest.shape import EMITTERS, PARTICLES
from cavesim.core.errors import ProtocolError, StateError
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.credentials import WALL
from cavesim.core.wire.envelope import Envelope, Message
from cavesim.core.wire.network import zenoh_message
from cavesim.core.wire.payloads.state_transfer import SnapshotChunk, SnapshotHeader, StateRequest
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.replies import asking
from cavesim.core.wire.snapshot import (
    CHUNK_PARTICLES,
    SnapshotAssembly,
    chunk_spans,
    transfer_seconds,
)
from cavesim.gpu.engine import ParticleSystem
from nodes.wall.confirmation import Confirmation

log = logging.getLogger("cavesim.snapshot")
BUFFERED_STATES = 2  # of the largest state, in bytes: what a fetch buffers at most
BUFFER_SLACK = 2**20  # bytes beyond them, for the headers of repliers not followed


class SnapshotLoad:
    """One snapshot streaming into a ParticleSystem: staged chunk by chunk, committed whole;
    the particles' records digest (the confirmation's) taken of the chunks in their order.

    Until `commit` succeeds the system's current state is untouched.
    """

    def __init__(self, system: ParticleSystem) -> None:
        self.system = system
        self.assembly: SnapshotAssembly | None = None
        self.chunks = 0  # chunks placed and digested: every one before the first missing
        self._digest: RecordsDigest | None = None
        self._early: dict[int, bytes] = {}  # chunks placed before one ahead of them came

    @property
    def whole(self) -> bool:
        """Whether every chunk the header announced is in."""
        return self.assembly is not None and self.chunks == self.assembly.header.chunks

    def feed(self, message: Message) -> None:
        """Take the next message of the stream: the header first, then chunks in any order."""
        if self.assembly is None:
            if not isinstance(message, SnapshotHeader):
                raise ProtocolError("unexpected", f"a {type(message).__name__} before the "
                                                  f"snapshot's header")
            self.assembly = SnapshotAssembly(message, self.system.capacity,
                                             len(self.system.emitters))
            self.system.begin_load(message.particles)
            self._digest = RecordsDigest(PARTICLES, message.particles)
        elif not isinstance(message, SnapshotChunk):
            raise ProtocolError("unexpected", f"a {type(message).__name__} among the "
                                              f"snapshot's chunks")
        else:
            self.system.write_particle_chunk(self.assembly.place(message), message.data)
            self._early[message.index] = message.data
            while self.chunks in self._early:  # zenoh keeps the order over one link
                self._digest.update(self._early.pop(self.chunks))
                self.chunks += 1

    def particles_digest(self) -> bytes:
        """The records digest of the particles staged (all of them: once `whole`)."""
        return self._digest.digest()

    def commit(self) -> SnapshotHeader:
        """Make the staged state current once every chunk is in and its checksum matches."""
        if self.assembly is None:
            raise ProtocolError("missing-chunks", "the snapshot's header never came")
        self.assembly.check_complete()
        header = self.assembly.header
        try:
            self.system.commit_load(header.emitters, header.seed, header.digest)
        except StateError as e:
            raise ProtocolError("bad-digest", str(e)) from e
        return header


def send_snapshot(query: zenoh.Query, key: str, system: ParticleSystem, frame: int,
                  seal: Callable[[Message], bytes],
                  chunk_particles: int = CHUNK_PARTICLES) -> int:
    """Answer `query` with the current state of `system`, frame `frame`, sealed by `seal`;
    the bytes sent (which the asker's serving budget is charged).

    A reply waits while the receiver's queue is full (zenoh closes a link blocked past its
    `wait_before_close`, 5 s by default); past the transfer's deadline the rest is not sent.
    """
    live = system.live_count
    deadline = time.monotonic() + transfer_seconds(live)
    header = SnapshotHeader(frame, system.scene.seed, live, chunk_particles,
                            system.checksum().digest, system.read_emitters())
    sent = 0
    try:
        sent += _reply(query, key, seal(header))
        for index, first, count in chunk_spans(live, chunk_particles):
            if time.monotonic() > deadline:
                log.warning("snapshot of frame %d: deadline passed after %d of %d chunks",
                            frame, index, header.chunks)
                break
            data = system.read_particle_chunk(first, count)
            sent += _reply(query, key, seal(SnapshotChunk(frame, index, data)))
    except zenoh.ZError as e:  # the receiver went away
        log.warning("snapshot of frame %d: a reply failed: %s", frame, zenoh_message(e))
    finally:
        query.drop()
    return sent


def _reply(query: zenoh.Query, key: str, data: bytes) -> int:
    query.reply(key, data)
    return len(data)


class SourceRefused(Exception):
    """The wall asked (its key) sent the wanted state's header, and every such stream was
    refused: asking it again would bring the same, so the resync ends and the master tries
    another source."""


def fetch_snapshot(session: zenoh.Session, key: str, system: ParticleSystem, request: bytes,
                   open_reply: Callable[[bytes], Envelope], wanted: StateRequest,
                   deadline: float, rejects: RejectCounter, failed: set[str],
                   confirmation: Confirmation | None = None,
                   received: Callable[[int], None] = lambda size: None
                   ) -> SnapshotHeader | None:
    """Ask `key` for the state `wanted` names (`request`: that request, sealed) and load it
    into `system`; its header, or None when nothing was loaded and asking again may help
    (nobody answered, the deadline passed, replies came faster than they were read);
    SourceRefused when every stream of the wanted state was refused (each counted).
    `received` is told the size of each reply read.

    Every reply must be signed by the wall asked (`wanted.node`), so the staged bytes are
    that wall's: a state whose checksum collides with the wanted one, sent by anyone else,
    is refused before any of it is staged. Every replier whose first reply is the wanted
    state's header is a stream to load: the first is followed (staged as it comes), the
    others are kept (up to the fetch's buffer) to be followed in turn should it be refused
    (it breaks, it is not what `confirmation`'s second wall holds, or its checksum is not
    the wanted one, which covers its seed) or should one of them be whole first (the one
    followed is then dropped for this query), so that a peer holding a stolen key of the
    wall asked costs no second query, however it sends or holds its stream. A replier that
    sent another state or a broken stream (`failed`, kept across the caller's attempts) is
    not heard again. The state becomes current only whole, confirmed (when a confirmer is
    named) and with the wanted checksum.
    """
    limit = BUFFERED_STATES * system.capacity * PARTICLE_BYTES + BUFFER_SLACK
    streams = _Streams(system, wanted, key, open_reply, rejects, failed, confirmation, limit)
    with asking(session, key, deadline, limit, streams.listen, payload=request,
                consolidation=zenoh.ConsolidationMode.NONE,  # the default keeps one per key
                congestion_control=zenoh.CongestionControl.BLOCK) as replies:
        for reply in replies:
            if replies.overflowed:
                log.warning("snapshot from %s: %d replies came faster than they were loaded; "
                            "asking again", key, replies.overflowed)
                return None
            replier = str(reply.replier_id)
            if reply.ok is None or not streams.listen(replier):
                continue
            data = reply.ok.payload.to_bytes()
            received(len(data))
            if (header := streams.take(replier, data)) is not None:
                return header
    return streams.end(deadline)


class _Streams:
    """The streams of the wanted state one state query brought, loaded one at a time (see
    `fetch_snapshot`)."""

    def __init__(self, system: ParticleSystem, wanted: StateRequest, key: str,
                 open_reply: Callable[[bytes], Envelope], rejects: RejectCounter,
                 failed: set[str], confirmation: Confirmation | None, limit: int) -> None:
        self.system, self.wanted, self.key, self.open_reply = system, wanted, key, open_reply
        self.rejects, self.failed, self.confirmation, self.limit = (rejects, failed,
                                                                    confirmation, limit)
        self.kept: dict[str, deque[tuple[Message, int]]] = {}  # replier -> messages not fed
        self.kept_bytes = 0
        self.dropped: set[str] = set()  # beyond the buffer, or left unfinished while another
        # was whole: not heard again in this query
        self.following: str | None = None
        self.load: SnapshotLoad | None = None
        self.refused = 0  # streams of the wanted state refused

    def listen(self, replier: str) -> bool:
        return replier not in self.failed and replier not in self.dropped

    def take(self, replier: str, data: bytes) -> SnapshotHeader | None:
        """Take one reply; the header of the state committed, if that made it whole."""
        try:
            envelope = self._opened(data)
            message = envelope.message
            if replier not in self.kept:
                _check_wanted(message, self.wanted)
        except ProtocolError as e:
            self._refuse(replier, e)
            return self._advance()
        if replier != self.following and self.kept_bytes + len(data) > self.limit:
            self._drop(replier)
            return self._advance()
        self.kept.setdefault(replier, deque()).append((message, len(data)))
        self.kept_bytes += len(data)
        if self.following is not None and self._whole(replier):
            self._drop(self.following)  # unfinished (held open?): its staged part is gone
        return self._advance()

    def end(self, deadline: float) -> SnapshotHeader | None:
        """After the query: None (ask again), or SourceRefused when there is no use."""
        if self.load is not None and time.monotonic() > deadline:
            log.warning("snapshot from %s: deadline passed while streaming", self.key)
        if self.refused and self.load is None and not self.dropped:
            raise SourceRefused(f"{self.refused} stream(s) of the state {self.wanted.node} "
                                f"was asked for were refused, and no other came")
        return None

    def _opened(self, data: bytes) -> Envelope:
        envelope = self.open_reply(data)
        envelope.check_signer(WALL, self.wanted.node)
        return envelope

    def _advance(self) -> SnapshotHeader | None:
        """Feed the followed stream what it has (following the next one kept when there is
        none); the header of the state committed, if one became whole and passed."""
        while True:
            if self.following is None:
                if not self.kept:
                    return None
                self.following = next((r for r in self.kept if self._whole(r)),
                                      next(iter(self.kept)))
                self.load = SnapshotLoad(self.system)
            queue = self.kept[self.following]
            if not queue:
                return None
            message, size = queue.popleft()
            self.kept_bytes -= size
            try:
                self.load.feed(message)
                if self.load.whole:
                    return self._commit()
            except ProtocolError as e:
                self._refuse(self.following, e)

    def _commit(self) -> SnapshotHeader:
        header = self.load.assembly.header
        if self.confirmation is not None:
            self.confirmation.check(PARTICLES, None, self.load.particles_digest(),
                                    _state_of(header))
            self.confirmation.check(EMITTERS, None, records_digest(
                EMITTERS, len(header.emitters), header.emitters.tobytes()), _state_of(header))
        return self.load.commit()

    def _refuse(self, replier: str, error: ProtocolError) -> None:
        """Count `error`, and hear `replier` no more."""
        self.rejects.reject(error, self.key)
        self.failed.add(replier)  # a wrong header or a broken stream: not followed again
        if replier in self.kept:
            self.refused += 1
        self._forget(replier)

    def _whole(self, replier: str) -> bool:
        """Whether a stream kept, not followed, holds its header and every chunk."""
        kept = self.kept.get(replier) if replier != self.following else None
        return bool(kept) and isinstance(kept[0][0], SnapshotHeader) \
            and len(kept) > kept[0][0].chunks

    def _drop(self, replier: str) -> None:
        """Hear `replier` no more in this query (not failed: it may be asked again)."""
        self._forget(replier)
        self.dropped.add(replier)

    def _forget(self, replier: str) -> None:
        self.kept_bytes -= sum(size for _, size in self.kept.pop(replier, ()))
        if replier == self.following:
            self.following = self.load = None


def _state_of(header: SnapshotHeader) -> tuple[int, int, int]:
    """(seed, live particles, emitters) of the state a snapshot's header announces."""
    return header.seed, header.particles, len(header.emitters)


def _check_wanted(message: Message, wanted: StateRequest) -> None:
    """ProtocolError unless `message` is the header of the wanted state."""
    if not isinstance(message, SnapshotHeader):
        raise ProtocolError("unexpected", f"a {type(message).__name__} before the snapshot's "
                                          f"header")
    if message.frame != wanted.frame or message.digest != wanted.digest:
        raise ProtocolError("wrong-snapshot", f"a snapshot of frame {message.frame} "
                                              f"({message.digest[:8]}); the master named "
                                              f"frame {wanted.frame} ({wanted.digest[:8]})")
