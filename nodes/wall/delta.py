"""Delta resync: a diverged node fetches only the records under the blocks of its checksum
tree that differ from a healthy node's, instead of the whole state.

The node asks the source for its tree top (fold-2 items, with its seed and live counts),
compares it with its own, asks for the fold-1 items (blocks) under the differing ones, then
for the invocation sums of the differing blocks, and fetches the records those differing
invocations summed (cavesim/core/digest/shape.py). The records are written into a staged
copy of its own state (`ParticleSystem.begin_patch`), which becomes current only if its
full checksum is the one the master named, and, when the master named a confirmer, once
a second wall has confirmed every page of records fetched and the emitters
(`nodes/wall/confirmation.py`): a bad, forged or partial delta changes nothing.
Anything else — other live counts, no answer, more than DELTA_SHARE of the blocks differing,
a staged checksum that does not match — is a `DeltaRefused`, and the node streams the full
snapshot instead (nodes/wall/snapshots.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.digest.records_digest import records_digest
from cavesim.core.digest.shape import (
    EMITTERS,
    FOLD,
    ITEM_WORDS,
    PARTICLES,
    RECORD_WORDS,
    WORKGROUP_SIZE,
    children,
    index_runs,
    invocation_records,
    plan,
)
from cavesim.core.errors import ProtocolError, StateError
from cavesim.core.records import EMITTER_DTYPE
from cavesim.core.wire.payloads.state_transfer import (
    MAX_BLOCK_INDICES,
    BlockQuery,
    BlockReply,
    BlockRequest,
)
from cavesim.gpu.engine import ParticleSystem
from nodes.wall.confirmation import Confirmation

DELTA_SHARE = 0.25  # of the blocks: beyond it the full snapshot is about as cheap

Ask = Callable[[BlockRequest], BlockReply | None]  # a BlockAsker of the source


class DeltaRefused(Exception):
    """No delta: why (the node then streams the full snapshot). `bad_data`: the source's
    records did not give the named state (its replier is not to be followed again);
    `refusal`: the refusal to count, if the confirmation refused them."""

    def __init__(self, reason: str, bad_data: bool = False,
                 refusal: ProtocolError | None = None) -> None:
        super().__init__(reason)
        self.bad_data, self.refusal = bad_data, refusal


@dataclass(frozen=True)
class Delta:
    """A delta that was loaded."""

    blocks: int  # differing blocks (fold-1 items)
    invocations: int  # differing invocation sums under them
    records: int  # records fetched and written (both streams)


def fetch_delta(system: ParticleSystem, ask: Ask, frame: int, source: str,
                digest: str, confirmation: Confirmation | None = None) -> Delta:
    """Load `source`'s state of `frame`, whose checksum is `digest`, by fetching only the
    records whose blocks differ from ours (each page of them, and the emitters after,
    confirmed by `confirmation`'s second wall when one is named); DeltaRefused when that
    cannot be done, NoConfirmation when the confirmer does not answer."""
    fetch = _Fetch(ask, frame, source, digest)
    top = fetch.reply(BlockQuery.TREE, 2, np.zeros(0, np.int64))
    _, particles, emitters = system.tree_state()
    if (top.particles, top.emitters) != (particles, emitters):
        raise DeltaRefused(f"live counts differ: {source} holds {top.particles} particles and "
                           f"{top.emitters} emitters, this node {particles} and {emitters}")
    if confirmation is not None:
        fetch.confirm = _Confirming(confirmation, (top.seed, particles, emitters))
    shape = plan(particles, emitters)
    theirs = _rows(top, 2)
    kids = np.array([b for i in np.flatnonzero(_differ(system.tree_items(
        2, np.arange(len(theirs))), theirs)) for b in children(2, int(i), shape.items[1])],
        np.int64)
    blocks = kids[_differ(system.tree_items(1, kids), fetch.items(1, kids))]
    if len(blocks) > max(1.0, DELTA_SHARE * shape.items[1]):
        raise DeltaRefused(f"{len(blocks)} of {shape.items[1]} blocks differ (more than "
                           f"{DELTA_SHARE:.0%})")
    invocations = np.array([b * FOLD + t for b in blocks for t in range(WORKGROUP_SIZE)],
                           np.int64)
    differing = invocations[_differ(system.tree_items(0, invocations),
                                    fetch.items(0, invocations))]
    records = [[], []]
    for invocation in differing:
        stream, group = shape.stream_group(int(invocation) // FOLD)
        live = (particles, emitters)[stream]
        records[stream].append(invocation_records(stream, group, int(invocation) % FOLD, live))
    wanted = [np.unique(np.concatenate([np.zeros(0, np.int64), *r])) for r in records]
    try:
        data = [fetch.records(stream, wanted[stream]) for stream in (PARTICLES, EMITTERS)]
        patched = _patched_emitters(system, wanted[EMITTERS], data[EMITTERS])
        if fetch.confirm is not None:
            fetch.confirm(EMITTERS, None, patched.tobytes())
    except ProtocolError as e:
        raise DeltaRefused(f"the records are not confirmed ({e})", True, e) from e
    _stage(system, wanted, data)
    try:
        system.commit_load(patched, top.seed, digest)
    except StateError as e:
        raise DeltaRefused(f"the patched state is not the named one ({e})", True) from e
    return Delta(len(blocks), len(differing), sum(len(w) for w in wanted))


class _Confirming:
    """Each page of records a delta fetched (or, with no indices, a whole stream as it will
    be), checked against the confirmer's digest of the same records."""

    def __init__(self, confirmation: Confirmation, state: tuple[int, int, int]) -> None:
        self.confirmation, self.state = confirmation, state

    def __call__(self, stream: int, indices: np.ndarray | None, data: bytes) -> None:
        count = len(data) // (RECORD_WORDS[stream] * 4)
        self.confirmation.check(stream, indices, records_digest(stream, count, data, indices),
                                self.state)


class _Fetch:
    """The source's replies to the delta's questions, in pages of MAX_BLOCK_INDICES."""

    def __init__(self, ask: Ask, frame: int, source: str, digest: str) -> None:
        self.ask, self.frame, self.source, self.digest = ask, frame, source, digest
        self.confirm: _Confirming | None = None

    def reply(self, query: BlockQuery, part: int, indices: np.ndarray) -> BlockReply:
        reply = self.ask(BlockRequest(self.frame, self.source, self.digest, query, part,
                                      tuple(int(i) for i in indices)))
        if reply is None:
            raise DeltaRefused(f"{self.source} did not answer a {query.name} question")
        return reply

    def pages(self, query: BlockQuery, part: int, indices: np.ndarray) -> bytes:
        return b"".join(self.reply(query, part, indices[i:i + MAX_BLOCK_INDICES]).data
                        for i in range(0, len(indices), MAX_BLOCK_INDICES))

    def items(self, level: int, indices: np.ndarray) -> np.ndarray:
        return np.frombuffer(self.pages(BlockQuery.TREE, level, indices),
                             "<u4").reshape(-1, ITEM_WORDS[level])

    def records(self, stream: int, indices: np.ndarray) -> bytes:
        """The records `indices` of `stream`, page by page, each page confirmed."""
        pages = []
        for i in range(0, len(indices), MAX_BLOCK_INDICES):
            page = indices[i:i + MAX_BLOCK_INDICES]
            pages.append(self.reply(BlockQuery.RECORDS, stream, page).data)
            if self.confirm is not None:
                self.confirm(stream, page, pages[-1])
        return b"".join(pages)


def _rows(reply: BlockReply, level: int) -> np.ndarray:
    return np.frombuffer(reply.data, "<u4").reshape(-1, ITEM_WORDS[level])


def _differ(ours: np.ndarray, theirs: np.ndarray) -> np.ndarray:
    return (ours != theirs).any(axis=1)


def _stage(system: ParticleSystem, wanted: list[np.ndarray], data: list[bytes]) -> None:
    """A copy of our particle stream with the fetched records in place, staged."""
    size = RECORD_WORDS[PARTICLES] * 4
    system.begin_patch()
    indices = wanted[PARTICLES]
    for first, end in index_runs(indices):
        system.write_particle_chunk(int(indices[first]), data[PARTICLES][first * size:end * size])


def _patched_emitters(system: ParticleSystem, indices: np.ndarray, data: bytes) -> np.ndarray:
    emitters = system.read_emitters()
    emitters[indices] = np.frombuffer(data, EMITTER_DTYPE)
    return emitters
