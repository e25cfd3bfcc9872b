"""Streamed snapshots without a network: the sender's replies, decoded and fed to another
system in any order; every broken stream is refused and leaves the receiver untouched."""

from __future__ import annotations

import random
import time

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene
from zenoh_doubles import RepliesSession, Reply

from cavesim.core.digest.shape import PARTICLES
from cavesim.core.errors import ProtocolError, StateError
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.envelope import decode, decode_envelope, encode
from cavesim.core.wire.payloads.state_transfer import (
    BlockQuery,
    BlockRequest,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
)
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.snapshot import TRANSFER_BASE, TRANSFER_RATE, chunk_spans, transfer_seconds
from cavesim.gpu.engine import FrameInput, ParticleSystem
from nodes.blocks import answer
from nodes.wall.snapshots import SnapshotLoad, SourceRefused, fetch_snapshot, send_snapshot

SESSION, KEY = "snap", generate().issue("wall", "front")  # the source's own key
FRAME = 12
CHUNK = 37  # particles per reply: about ten chunks, the last one short


class CapturedQuery:
    """A zenoh query stand-in that keeps what the sender replies."""

    def __init__(self) -> None:
        self.replies: list[bytes] = []
        self.dropped = False

    def reply(self, key: str, payload: bytes) -> None:
        self.replies.append(payload)

    def drop(self) -> None:
        self.dropped = True


def seal(message) -> bytes:
    return encode(message, SESSION, KEY)


def unseal(data: bytes):
    return decode(data, SESSION, KEY)


def stepped(ctx, seed: int, frames: int) -> ParticleSystem:
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=4000, seed=seed))
    rng = np.random.default_rng(seed)
    for _ in range(frames):
        system.step(FrameInput(1 / 60, np.array([[1, rng.integers(9), rng.integers(64)],
                                                 [0, 1, rng.integers(64)], [0, 0, 1]])))
    return system


@pytest.fixture
def source(ctx):
    system = stepped(ctx, seed=7, frames=40)
    assert system.live_count > 5 * CHUNK
    yield system
    system.release()


@pytest.fixture
def target(ctx):
    system = stepped(ctx, seed=8, frames=3)  # another seed: the load must re-seed it
    yield system
    system.release()


def snapshot_of(system: ParticleSystem) -> list:
    query = CapturedQuery()
    send_snapshot(query, "cavesim/snap/state/front", system, FRAME, seal, CHUNK)
    assert query.dropped
    return [unseal(data) for data in query.replies]


def state_of(system: ParticleSystem) -> tuple:
    return system.checksum(), system.live_count, system.scene.seed, system.read_emitters().tobytes()


def refusal(target: ParticleSystem, messages: list) -> str:
    """Feed `messages` and commit; the reason of the first refusal (the state must stay)."""
    before = state_of(target)
    load = SnapshotLoad(target)
    with pytest.raises(ProtocolError) as error:
        for message in messages:
            load.feed(message)
        load.commit()
    assert state_of(target) == before
    target.step(FrameInput(1 / 60, np.eye(3)))  # and it still steps
    return error.value.reason


def test_chunks_in_any_order_load_the_source_state(source, target):
    header, *chunks = snapshot_of(source)
    assert isinstance(header, SnapshotHeader) and header.chunks == len(chunks) > 5
    assert len(chunks[-1].data) < CHUNK * PARTICLE_BYTES
    random.Random(3).shuffle(chunks)
    load = SnapshotLoad(target)
    for message in (header, *chunks):
        load.feed(message)
    assert load.commit() == header
    # what a confirmer computes from its GPU state is what the receiver took of the chunks
    whole = BlockRequest(FRAME, "front", header.digest, BlockQuery.DIGEST, PARTICLES)
    assert answer(source, whole, "front").data == load.particles_digest()
    assert target.checksum() == source.checksum() and target.scene.seed == source.scene.seed
    np.testing.assert_array_equal(target.read_particles(), source.read_particles())
    frame = FrameInput(1 / 60, np.array([[1, 3, 5], [0, 1, 7], [0, 0, 1]]))
    source.step(frame)
    target.step(frame)
    assert target.checksum() == source.checksum()


def test_an_empty_state_is_a_header_alone(ctx, target):
    empty = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=4000, seed=7))
    (header,) = snapshot_of(empty)
    assert header.particles == 0 and header.chunks == 0
    load = SnapshotLoad(target)
    load.feed(header)
    load.commit()
    assert target.checksum() == empty.checksum()
    empty.release()


def test_a_missing_chunk_is_refused(source, target):
    header, *chunks = snapshot_of(source)
    del chunks[4]
    assert refusal(target, [header, *chunks]) == "missing-chunks"


def test_a_duplicate_chunk_is_refused(source, target):
    header, *chunks = snapshot_of(source)
    assert refusal(target, [header, *chunks[:3], chunks[1], *chunks[3:]]) == "duplicate-chunk"


def test_a_chunk_out_of_range_is_refused(source, target):
    header, *chunks = snapshot_of(source)
    stray = SnapshotChunk(FRAME, header.chunks, chunks[0].data)
    assert refusal(target, [header, stray]) == "chunk-out-of-range"


def test_a_chunk_of_another_frame_or_size_is_refused(source, target):
    header, first, *_ = snapshot_of(source)
    assert refusal(target, [header, SnapshotChunk(FRAME + 1, 0, first.data)]) == "wrong-frame"
    assert refusal(target, [header, SnapshotChunk(FRAME, 0, first.data[:-PARTICLE_BYTES])]) \
        == "bad-chunk-size"


def test_a_bad_digest_is_refused_after_every_chunk_is_staged(source, target):
    header, *chunks = snapshot_of(source)
    forged = SnapshotHeader(header.frame, header.seed, header.particles,
                            header.chunk_particles, "0" * 32, header.emitters)
    assert refusal(target, [forged, *chunks]) == "bad-digest"
    flipped = bytearray(chunks[2].data)
    flipped[5] ^= 1
    chunks[2] = SnapshotChunk(FRAME, 2, bytes(flipped))
    assert refusal(target, [header, *chunks]) == "bad-digest"


def test_counts_this_node_cannot_hold_are_refused(source, target):
    header, *chunks = snapshot_of(source)
    too_many = SnapshotHeader(FRAME, 7, target.capacity + 1, CHUNK, header.digest,
                              header.emitters)
    assert refusal(target, [too_many]) == "wrong-counts"
    fewer_emitters = SnapshotHeader(FRAME, 7, header.particles, CHUNK, header.digest,
                                    header.emitters[:0])
    assert refusal(target, [fewer_emitters, *chunks]) == "wrong-counts"


def test_a_chunk_before_the_header_is_refused(source, target):
    header, *chunks = snapshot_of(source)
    assert refusal(target, [chunks[0], header]) == "unexpected"
    assert refusal(target, []) == "missing-chunks"


def test_a_staged_load_is_dropped_by_the_next_step(source, target):
    target.begin_load(CHUNK)
    target.write_particle_chunk(0, source.read_particle_chunk(0, CHUNK))
    target.step(FrameInput(1 / 60, np.eye(3)))
    with pytest.raises(StateError, match="needs a begin_load"):
        target.commit_load()
    with pytest.raises(StateError, match="not whole"):
        target.begin_load(2)
        target.write_particle_chunk(1, bytes(2 * PARTICLE_BYTES))


def test_chunk_spans_cover_the_stream_once():
    spans = list(chunk_spans(1000, 97))
    assert [index for index, _, _ in spans] == list(range(11))
    assert sum(count for _, _, count in spans) == 1000 and spans[-1] == (10, 970, 30)
    assert list(chunk_spans(0, 97)) == []


def test_transfer_deadline_grows_with_the_state():
    assert transfer_seconds(0) == TRANSFER_BASE
    two_gb = 53_687_091
    assert transfer_seconds(two_gb) == pytest.approx(TRANSFER_BASE + two_gb * 40 / TRANSFER_RATE)
    assert transfer_seconds(two_gb) > 60


# -- fetching: only the named state, whole and verified, from a replier that has not failed --

def replies_of(replier: str, system: ParticleSystem, frame: int = FRAME) -> list[Reply]:
    query = CapturedQuery()
    send_snapshot(query, "cavesim/snap/state/front", system, frame, seal, CHUNK)
    return [Reply(replier, data) for data in query.replies]


def fetch(target: ParticleSystem, replies: list[Reply], wanted: StateRequest,
          failed: set[str] | None = None) -> tuple:
    """(the header loaded, None, or "source refused"; the refusals; the repliers failed)."""
    rejects = RejectCounter("test")
    failed = set() if failed is None else failed
    try:
        header = fetch_snapshot(RepliesSession(replies), "cavesim/snap/state/front", target,
                                b"", lambda data: decode_envelope(data, SESSION, KEY), wanted,
                                time.monotonic() + 30, rejects, failed)
    except SourceRefused:
        header = "source refused"
    return header, dict(rejects.counts), failed


def test_an_old_snapshot_first_is_ignored_and_the_named_one_loaded(ctx, source, target):
    old = stepped(ctx, seed=7, frames=30)  # the same node's state of an earlier frame
    wanted = StateRequest(FRAME, "front", source.checksum().digest)
    header, rejected, failed = fetch(target, replies_of("rogue", old, FRAME - 10)
                                     + replies_of("front", source), wanted)
    old.release()
    assert header is not None and header.frame == FRAME
    assert target.checksum() == source.checksum()
    assert rejected == {"wrong-snapshot": 1} and failed == {"rogue"}  # its stream not followed


def test_a_snapshot_that_does_not_fit_the_scene_is_refused_and_nothing_is_touched(
        ctx, source, target):
    wanted = StateRequest(FRAME, "front", source.checksum().digest)
    header, *_ = snapshot_of(source)
    misfit = SnapshotHeader(FRAME, header.seed, target.capacity + 1, CHUNK, header.digest,
                            header.emitters)
    before = state_of(target)
    loaded, rejected, failed = fetch(target, [Reply("rogue", seal(misfit))], wanted)
    assert loaded == "source refused" and rejected == {"wrong-counts": 1}
    assert failed == {"rogue"}
    assert state_of(target) == before


def test_a_forged_stream_fails_its_digest_and_its_replier_is_not_followed_again(source, target):
    wanted = StateRequest(FRAME, "front", source.checksum().digest)
    replies = replies_of("rogue", source)
    tampered = unseal(replies[3].ok.payload.to_bytes())
    data = bytearray(tampered.data)
    data[0] ^= 1
    replies[3] = Reply("rogue", seal(SnapshotChunk(FRAME, tampered.index, bytes(data))))
    before = state_of(target)
    loaded, rejected, failed = fetch(target, replies, wanted)
    assert loaded == "source refused" and rejected == {"bad-digest": 1}
    assert failed == {"rogue"} and state_of(target) == before
    loaded, _, _ = fetch(target, replies_of("rogue", source) + replies_of("front", source),
                         wanted, failed)
    assert loaded is not None and target.checksum() == source.checksum()


def test_a_forged_stream_first_leaves_the_others_of_the_query_to_load(source, target):
    """Every stream of the named state is kept while the first is followed: once the first
    breaks, the next one of the same query is loaded (no second query)."""
    wanted = StateRequest(FRAME, "front", source.checksum().digest)
    forged = replies_of("thief", source)
    shuffled = list(reversed(forged[1:]))  # the chunks in reverse order: placed all the same
    tampered = unseal(shuffled[0].ok.payload.to_bytes())
    shuffled[0] = Reply("thief", seal(SnapshotChunk(FRAME, tampered.index, bytes(
        len(tampered.data)))))
    honest = replies_of("front", source)
    interleaved = [forged[0], honest[0], *(r for pair in zip(shuffled, honest[1:], strict=True)
                                          for r in pair)]
    loaded, rejected, failed = fetch(target, interleaved, wanted)
    assert loaded is not None and target.checksum() == source.checksum()
    assert rejected == {"bad-digest": 1} and failed == {"thief"}
