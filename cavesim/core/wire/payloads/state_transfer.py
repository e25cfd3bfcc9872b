"""A node's state on the wire, asked for by a resyncing node or the master's forensics: a
state request answered by a snapshot's header and chunks, and block requests answered by
the items of the checksum's tree, whole records, or the cryptographic digest of records (a
resync's confirmation). A request ends in a fresh nonce (a node takes each nonce once: a
replayed request is refused) and the name of its asker (whose serving budget it is charged
to)."""

from __future__ import annotations

import secrets
import struct
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from cavesim.core.digest.history import HISTORY_FRAMES
from cavesim.core.digest.records_digest import DIGEST_BYTES
from cavesim.core.digest.shape import ITEM_WORDS, RECORD_WORDS
from cavesim.core.errors import ProtocolError
from cavesim.core.limits import MAX_EMITTERS, MAX_PARTICLES
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.wire.payloads._fields import digest_bytes, name_bytes, read_name

MAX_CHUNK_PARTICLES = 2**23 // PARTICLE_BYTES  # 8 MiB: the largest message (network.py)
MAX_BLOCK_INDICES = 16_384  # items or records one block request names (64 KiB)
MAX_BLOCK_BYTES = 4 * 2**20  # of a block reply's data, like a snapshot's chunk
_SNAPSHOT = struct.Struct("<QIII16s")  # seed, particles, emitters, chunk particles, digest
_CHUNK = struct.Struct("<I")  # chunk index, then whole particle records
_STATE_REQUEST = struct.Struct("<16s")  # the digest of the state asked for
_BLOCK_REQUEST = struct.Struct("<16sBBI")  # digest, query, part, index count; then indices
_ASKED = struct.Struct("<Q")  # a request's nonce, then its asker's name
MASTER_ASKER = "master"  # the asker the master's block questions name
_BLOCK_REPLY = struct.Struct("<BBQIIB")  # query, part, seed, counts, history frames
_HISTORY_FRAME = struct.Struct("<QII")  # frame, particles, emitters


@dataclass(frozen=True)
class StateRequest:
    """A resyncing node's query for `node`'s state of `frame`, whose checksum is `digest`."""

    frame: int
    node: str
    digest: str
    asker: str = ""  # the node asking ("master": the master)
    nonce: int = field(default_factory=lambda: secrets.randbits(64))


@dataclass(frozen=True)
class SnapshotHeader:
    """The first reply to a state query: the state that the chunks after it add up to."""

    frame: int
    seed: int
    particles: int  # live particles, streamed in chunks of `chunk_particles` records
    chunk_particles: int
    digest: str  # the state's checksum (32 hex digits): the load commits only if it matches
    emitters: np.ndarray = field(repr=False)  # EMITTER_DTYPE, whole: at most 64 KiB

    @property
    def chunks(self) -> int:
        """How many chunks follow (derived, so it cannot disagree with the counts)."""
        return -(-self.particles // self.chunk_particles)


@dataclass(frozen=True)
class SnapshotChunk:
    """Chunk `index` of a snapshot: particles [index x chunk_particles, ...), whole records."""

    frame: int
    index: int
    data: bytes = field(repr=False)


class BlockQuery(IntEnum):
    """What a block request asks a node for, of the state it holds (`part` says which)."""

    TREE = 1  # items of one level of the checksum's tree (part: the level, 0 sums, 1, 2),
    # with the state's seed and counts; no indices: the whole level
    HISTORY = 2  # fold-1 items (part 1) of every frame its history ring holds up to `frame`
    RECORDS = 3  # whole records of one stream (part: 0 particles, 1 emitters)
    DIGEST = 4  # the cryptographic digest of records of one stream (part as RECORDS): those
    # named; no indices: the whole live stream (cavesim/core/digest/records_digest.py)


_PARTS = {BlockQuery.TREE: (0, 1, 2), BlockQuery.HISTORY: (1,), BlockQuery.RECORDS: (0, 1),
          BlockQuery.DIGEST: (0, 1)}
_WHOLE = (BlockQuery.TREE, BlockQuery.DIGEST)  # may name no indices: all there are


@dataclass(frozen=True)
class BlockRequest:
    """A question about `node`'s state of `frame`, whose checksum is `digest` (a node that
    holds another state refuses it): the master's forensics, or a resyncing node's delta."""

    frame: int
    node: str
    digest: str
    query: BlockQuery
    part: int
    indices: tuple[int, ...] = ()  # ascending, at most MAX_BLOCK_INDICES
    asker: str = ""  # the node asking ("master": the master)
    nonce: int = field(default_factory=lambda: secrets.randbits(64))


@dataclass(frozen=True)
class HistoryFrame:
    """A frame of a node's history ring, and the live counts of its state then."""

    frame: int
    particles: int
    emitters: int


@dataclass(frozen=True)
class BlockReply:
    """A node's answer to a block request: the items or records asked for, in the order
    asked (HISTORY: frame by frame), with the state's seed and live counts."""

    frame: int
    node: str
    query: BlockQuery
    part: int
    seed: int
    particles: int
    emitters: int
    data: bytes = field(repr=False)
    history: tuple[HistoryFrame, ...] = ()  # HISTORY: the frames of `data`, oldest first

    @property
    def unit(self) -> int:
        """Bytes of one item or record of the reply's data."""
        if self.query is BlockQuery.RECORDS:
            return RECORD_WORDS[self.part] * 4
        if self.query is BlockQuery.DIGEST:
            return DIGEST_BYTES
        return ITEM_WORDS[self.part] * 4


def write_asked(asker: str, nonce: int) -> bytes:
    """A request's tail: its nonce and its asker."""
    if not 0 <= nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {nonce}")
    return _ASKED.pack(nonce) + name_bytes(asker, optional=True)


def read_asked(tail: bytes, what: str) -> tuple[str, int]:
    """(asker, nonce) of a request's tail, which must end there."""
    if len(tail) < _ASKED.size:
        raise ProtocolError("bad-payload", f"{what} ends before its nonce")
    (nonce,) = _ASKED.unpack_from(tail)
    asker, rest = read_name(tail[_ASKED.size:], optional=True)
    if rest:
        raise ProtocolError("bad-payload", f"{len(rest)} stray bytes after a {what}")
    return asker, nonce


def write_state_request(m: StateRequest) -> bytes:
    return name_bytes(m.node) + _STATE_REQUEST.pack(digest_bytes(m.digest)) + write_asked(
        m.asker, m.nonce)


def read_state_request(frame: int, payload: bytes) -> StateRequest:
    node, rest = read_name(payload)
    if len(rest) < _STATE_REQUEST.size:
        raise ProtocolError("bad-payload", f"state request body of {len(rest)} bytes, "
                                           f"expected at least {_STATE_REQUEST.size}")
    (digest,) = _STATE_REQUEST.unpack_from(rest)
    asker, nonce = read_asked(rest[_STATE_REQUEST.size:], "state request")
    return StateRequest(frame, node, digest.hex(), asker, nonce)


def write_snapshot(m: SnapshotHeader) -> bytes:
    emitters = np.ascontiguousarray(m.emitters, dtype=EMITTER_DTYPE)
    if not (0 <= m.particles <= MAX_PARTICLES and len(emitters) <= MAX_EMITTERS
            and 1 <= m.chunk_particles <= MAX_CHUNK_PARTICLES):
        raise ValueError(f"a snapshot holds at most {MAX_PARTICLES} particles and "
                         f"{MAX_EMITTERS} emitters in chunks of 1 to "
                         f"{MAX_CHUNK_PARTICLES} particles, got {m.particles}, "
                         f"{len(emitters)} and {m.chunk_particles}")
    return _SNAPSHOT.pack(m.seed, m.particles, len(emitters), m.chunk_particles,
                          digest_bytes(m.digest)) + emitters.tobytes()


def read_snapshot(frame: int, payload: bytes) -> SnapshotHeader:
    if len(payload) < _SNAPSHOT.size:
        raise ProtocolError("bad-payload", f"snapshot header of {len(payload)} bytes is too "
                                           f"short")
    seed, particles, emitters, chunk, digest = _SNAPSHOT.unpack_from(payload)
    if particles > MAX_PARTICLES or emitters > MAX_EMITTERS \
            or not 1 <= chunk <= MAX_CHUNK_PARTICLES \
            or len(payload) != _SNAPSHOT.size + emitters * EMITTER_DTYPE.itemsize:
        raise ProtocolError("bad-payload", f"snapshot of {particles} particles in chunks of "
                                           f"{chunk} and {emitters} emitters does not fit "
                                           f"{len(payload)} bytes or the limits")
    e = np.frombuffer(payload, EMITTER_DTYPE, emitters, _SNAPSHOT.size)
    return SnapshotHeader(frame, seed, particles, chunk, digest.hex(), e.copy())


def write_chunk(m: SnapshotChunk) -> bytes:
    records, rest = divmod(len(m.data), PARTICLE_BYTES)
    if rest or not 1 <= records <= MAX_CHUNK_PARTICLES or not 0 <= m.index < MAX_PARTICLES:
        raise ValueError(f"a chunk is 1 to {MAX_CHUNK_PARTICLES} whole {PARTICLE_BYTES}-byte "
                         f"records with an index below {MAX_PARTICLES}, got "
                         f"{len(m.data)} bytes at index {m.index}")
    return _CHUNK.pack(m.index) + bytes(m.data)


def read_chunk(frame: int, payload: bytes) -> SnapshotChunk:
    records, rest = divmod(len(payload) - _CHUNK.size, PARTICLE_BYTES)
    if len(payload) < _CHUNK.size or rest or not 1 <= records <= MAX_CHUNK_PARTICLES:
        raise ProtocolError("bad-payload", f"snapshot chunk of {len(payload)} bytes is not an "
                                           f"index and 1 to {MAX_CHUNK_PARTICLES} whole "
                                           f"{PARTICLE_BYTES}-byte records")
    (index,) = _CHUNK.unpack_from(payload)
    if index >= MAX_PARTICLES:
        raise ProtocolError("bad-value", f"chunk index {index} is beyond any snapshot "
                                         f"(at most {MAX_PARTICLES} particles)")
    return SnapshotChunk(frame, index, payload[_CHUNK.size:])


def write_block_request(m: BlockRequest) -> bytes:
    indices = np.asarray(m.indices, dtype=np.int64)
    if m.part not in _PARTS[m.query] or len(indices) > MAX_BLOCK_INDICES \
            or (indices.size and (indices[0] < 0 or indices[-1] >= 2**32
                                  or np.any(np.diff(indices) <= 0))) \
            or (m.query not in _WHOLE and not indices.size):
        raise ValueError(f"a {m.query.name} block request names part {m.part} (allowed: "
                         f"{_PARTS[m.query]}) and 1 to {MAX_BLOCK_INDICES} ascending indices "
                         f"(a TREE or DIGEST request may name none), got {len(indices)}")
    return name_bytes(m.node) + _BLOCK_REQUEST.pack(
        digest_bytes(m.digest), m.query, m.part, len(indices)) + indices.astype(
        "<u4").tobytes() + write_asked(m.asker, m.nonce)


def read_block_request(frame: int, payload: bytes) -> BlockRequest:
    node, rest = read_name(payload)
    if len(rest) < _BLOCK_REQUEST.size:
        raise ProtocolError("bad-payload", f"block request body of {len(rest)} bytes is too "
                                           f"short")
    digest, query, part, count = _BLOCK_REQUEST.unpack_from(rest)
    if query not in BlockQuery.__members__.values() or part not in _PARTS[BlockQuery(query)]:
        raise ProtocolError("bad-value", f"block query {query} of part {part} is unknown")
    end = _BLOCK_REQUEST.size + 4 * count
    if count > MAX_BLOCK_INDICES or len(rest) < end:
        raise ProtocolError("bad-payload", f"a block request of {count} indices in "
                                           f"{len(rest)} bytes (at most {MAX_BLOCK_INDICES})")
    asker, nonce = read_asked(rest[end:], "block request")
    indices = np.frombuffer(rest, "<u4", count, _BLOCK_REQUEST.size).astype(np.int64)
    if np.any(np.diff(indices) <= 0) or (query not in _WHOLE and not count):
        raise ProtocolError("bad-value", "block request indices must be ascending, and only "
                                         "a TREE or DIGEST request may name none")
    return BlockRequest(frame, node, digest.hex(), BlockQuery(query), part,
                        tuple(indices.tolist()), asker, nonce)


def write_block_reply(m: BlockReply) -> bytes:
    if m.part not in _PARTS[m.query] or len(m.data) > MAX_BLOCK_BYTES \
            or len(m.data) % m.unit or len(m.history) > HISTORY_FRAMES \
            or not (0 <= m.particles <= MAX_PARTICLES and 0 <= m.emitters <= MAX_EMITTERS):
        raise ValueError(f"a block reply holds whole items or records of at most "
                         f"{MAX_BLOCK_BYTES} bytes, {HISTORY_FRAMES} history frames and counts "
                         f"within the limits, got {len(m.data)} bytes, {len(m.history)} "
                         f"frames, {m.particles} and {m.emitters}")
    history = b"".join(_HISTORY_FRAME.pack(h.frame, h.particles, h.emitters)
                       for h in m.history)
    return name_bytes(m.node) + _BLOCK_REPLY.pack(
        m.query, m.part, m.seed, m.particles, m.emitters, len(m.history)) + history + m.data


def read_block_reply(frame: int, payload: bytes) -> BlockReply:
    node, rest = read_name(payload)
    if len(rest) < _BLOCK_REPLY.size:
        raise ProtocolError("bad-payload", f"block reply body of {len(rest)} bytes is too "
                                           f"short")
    query, part, seed, particles, emitters, frames = _BLOCK_REPLY.unpack_from(rest)
    if query not in BlockQuery.__members__.values() or part not in _PARTS[BlockQuery(query)]:
        raise ProtocolError("bad-value", f"block query {query} of part {part} is unknown")
    if particles > MAX_PARTICLES or emitters > MAX_EMITTERS or frames > HISTORY_FRAMES:
        raise ProtocolError("bad-value", f"a block reply of {particles} particles, {emitters} "
                                         f"emitters and {frames} history frames is beyond the "
                                         f"limits")
    start = _BLOCK_REPLY.size + frames * _HISTORY_FRAME.size
    history = tuple(HistoryFrame(*_HISTORY_FRAME.unpack_from(rest, _BLOCK_REPLY.size + i *
                                                             _HISTORY_FRAME.size))
                    for i in range(frames)) if len(rest) >= start else ()
    reply = BlockReply(frame, node, BlockQuery(query), part, seed, particles, emitters,
                       rest[start:], history)
    if len(rest) < start or len(reply.data) > MAX_BLOCK_BYTES or len(reply.data) % reply.unit:
        raise ProtocolError("bad-payload", f"a block reply's data of {len(rest) - start} "
                                           f"bytes is not whole {reply.unit}-byte items "
                                           f"within {MAX_BLOCK_BYTES} bytes")
    return reply
