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
from collections.abc import Callable

import zenoh

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

log = logging.getLogger("cavesim.snapshot")
BUFFERED_STATES = 2  # of the largest state, in bytes: what a fetch buffers at most
BUFFER_SLACK = 2**20  # bytes beyond them, for the headers of repliers not followed


class SnapshotLoad:
    """One snapshot streaming into a ParticleSystem: staged chunk by chunk, committed whole.

    Until `commit` succeeds the system's current state is untouched.
    """

    def __init__(self, system: ParticleSystem) -> None:
        self.system = system
        self.assembly: SnapshotAssembly | None = None
        self.chunks = 0  # chunks placed (each at most once)

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
        elif not isinstance(message, SnapshotChunk):
            raise ProtocolError("unexpected", f"a {type(message).__name__} among the "
                                              f"snapshot's chunks")
        else:
            self.system.write_particle_chunk(self.assembly.place(message), message.data)
            self.chunks += 1

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


def fetch_snapshot(session: zenoh.Session, key: str, system: ParticleSystem, request: bytes,
                   open_reply: Callable[[bytes], Envelope], wanted: StateRequest,
                   deadline: float, rejects: RejectCounter, failed: set[str],
                   received: Callable[[int], None] = lambda size: None
                   ) -> SnapshotHeader | None:
    """Ask `key` for the state `wanted` names (`request`: that request, sealed) and load it
    into `system`; its header, or None when nothing was loaded (nobody answered, the
    deadline passed, the stream came faster than it was loaded, or it was refused:
    counted). `received` is told the size of each reply followed.

    Every reply must be signed by the wall asked (`wanted.node`), so the staged bytes are
    that wall's: a state whose checksum collides with the wanted one, sent by anyone else,
    is refused before any of it is staged. Only a stream whose header is of the wanted
    frame and checksum is followed, from the first replier that sends one; other repliers
    are not heard, and a replier that sent
    another state or a broken stream (`failed`, kept across the caller's attempts) is not
    heard again: the attempt ends at once, and the caller asks again. The state becomes
    current only whole and with the wanted checksum (which covers its seed).
    """
    load = SnapshotLoad(system)
    source: str | None = None

    def listen(replier: str) -> bool:
        return replier not in failed and source in (None, replier)

    limit = BUFFERED_STATES * system.capacity * PARTICLE_BYTES + BUFFER_SLACK
    with asking(session, key, deadline, limit, listen, payload=request,
                consolidation=zenoh.ConsolidationMode.NONE,  # the default keeps one per key
                congestion_control=zenoh.CongestionControl.BLOCK) as replies:
        for reply in replies:
            if replies.overflowed:
                log.warning("snapshot from %s: %d replies came faster than they were loaded; "
                            "asking again", key, replies.overflowed)
                return None
            replier = str(reply.replier_id)
            if reply.ok is None or not listen(replier):
                continue
            data = reply.ok.payload.to_bytes()
            received(len(data))
            try:
                envelope = open_reply(data)
                envelope.check_signer(WALL, wanted.node)
                message = envelope.message
                if source is None:
                    _check_wanted(message, wanted)
                    source = replier
                load.feed(message)
            except ProtocolError as e:
                rejects.reject(e, key)
                failed.add(replier)  # a wrong header or a broken stream: not followed again
                if source == replier:
                    return None
            if load.whole:
                break
    if load.assembly is None:
        return None
    if not load.whole and time.monotonic() > deadline:
        log.warning("snapshot from %s: deadline passed while streaming", key)
    try:
        return load.commit()
    except ProtocolError as e:
        rejects.reject(e, key)
        failed.add(source)
        return None


def _check_wanted(message: Message, wanted: StateRequest) -> None:
    """ProtocolError unless `message` is the header of the wanted state."""
    if not isinstance(message, SnapshotHeader):
        raise ProtocolError("unexpected", f"a {type(message).__name__} before the snapshot's "
                                          f"header")
    if message.frame != wanted.frame or message.digest != wanted.digest:
        raise ProtocolError("wrong-snapshot", f"a snapshot of frame {message.frame} "
                                              f"({message.digest[:8]}); the master named "
                                              f"frame {wanted.frame} ({wanted.digest[:8]})")
