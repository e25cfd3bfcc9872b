"""The shape of the checksum's hash tree: how many items each level has for given live
counts, and which words, hence which records, each item covers.

The sums pass gives one item per invocation (level 0: two uint32 sums); invocation t of
work group g of a stream reads that stream's words g·WORDS_PER_GROUP + k·WORKGROUP_SIZE + t,
k < WORDS_PER_THREAD. Fold 1 absorbs FOLD level-0 items per item; as FOLD equals the work
group size, fold-1 item j is exactly work group j's sums: one *block* of WORDS_PER_GROUP
words of one stream (the particle stream's groups first, then the emitter stream's).
Fold 2 absorbs FOLD blocks per item, and the digest absorbs the seed, the counts and the
fold-2 items. Comparing two nodes' trees top-down (fold 2, fold 1, sums) finds the blocks,
then the invocations, and so the records where their states differ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.records import EMITTER_WORDS, PARTICLE_WORDS

WORKGROUP_SIZE = 64
WORDS_PER_THREAD = 256  # 10M words (1M particles) leave 39,168 sums to fold
FOLD = 64  # items each fold invocation absorbs in order
WORDS_PER_GROUP = WORKGROUP_SIZE * WORDS_PER_THREAD
assert FOLD == WORKGROUP_SIZE  # so that a fold-1 item is one work group's block of words
ITEM_WORDS = (2, 4, 4)  # uint32 words of one item of level 0 (the sums), 1 and 2
PARTICLES, EMITTERS = 0, 1  # the streams, in the order the sums pass covers them
STREAMS = ("particles", "emitters")
RECORD_WORDS = (PARTICLE_WORDS, EMITTER_WORDS)


def group_count(words: int) -> int:
    """Work groups of the sums pass over `words` words of one stream."""
    return -(-words // WORDS_PER_GROUP)


@dataclass(frozen=True)
class Plan:
    """How many work groups and items each pass has for given live counts."""

    particle_groups: int
    emitter_groups: int  # 0 or 1 for up to MAX_EMITTERS records

    @property
    def sums_groups(self) -> int:
        """Work groups of the sums pass: the particle stream's, then the emitter stream's."""
        return self.particle_groups + self.emitter_groups

    @property
    def items(self) -> tuple[int, int, int]:
        """Items entering fold 1 (the sums), fold 2 and the digest."""
        sums = self.sums_groups * WORKGROUP_SIZE
        level_1 = -(-sums // FOLD)
        return sums, level_1, -(-level_1 // FOLD)

    def fold_groups(self, level: int) -> int:
        """Work groups of fold `level` (1 or 2): one invocation per item it writes."""
        return -(-self.items[level] // WORKGROUP_SIZE)

    def stream_groups(self, stream: int) -> int:
        return self.emitter_groups if stream == EMITTERS else self.particle_groups

    def block(self, stream: int, group: int) -> int:
        """The fold-1 item (the block) of work group `group` of `stream`."""
        return group + (self.particle_groups if stream == EMITTERS else 0)

    def stream_group(self, block: int) -> tuple[int, int]:
        """(stream, work group in it) of fold-1 item `block`."""
        if block < self.particle_groups:
            return PARTICLES, block
        return EMITTERS, block - self.particle_groups


def plan(particles: int, emitters: int) -> Plan:
    return Plan(group_count(particles * PARTICLE_WORDS), group_count(emitters * EMITTER_WORDS))


def children(level: int, item: int, below: int) -> range:
    """The items of level `level - 1` (which has `below` items) that item `item` of level
    `level` absorbed."""
    return range(item * FOLD, min(item * FOLD + FOLD, below))


def invocation_words(group: int, thread: int, words: int) -> np.ndarray:
    """The word indices (within its stream of `words` live words) that invocation `thread`
    of work group `group` summed."""
    read = group * WORDS_PER_GROUP + np.arange(WORDS_PER_THREAD, dtype=np.int64) \
        * WORKGROUP_SIZE + thread
    return read[read < words]


def invocation_records(stream: int, group: int, thread: int, records: int) -> np.ndarray:
    """The records of `stream` (which has `records` live ones) whose words that invocation
    summed: a word of one of them changed, so did its sums."""
    words = invocation_words(group, thread, records * RECORD_WORDS[stream])
    return np.unique(words // RECORD_WORDS[stream])


def index_runs(indices: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) positions in `indices` (ascending) of each run of consecutive values:
    one buffer read per run."""
    if not len(indices):
        return []
    starts = np.flatnonzero(np.diff(indices, prepend=indices[0] - 2) != 1).tolist()
    return list(zip(starts, [*starts[1:], len(indices)], strict=True))


def block_of_record(stream: int, record: int) -> int:
    """The work group of `stream` whose block holds the first word of `record`."""
    return record * RECORD_WORDS[stream] // WORDS_PER_GROUP


@dataclass(frozen=True)
class StateChecksum:
    digest: str  # 32 hex digits over the seed, both streams, their order and the live counts
    particles: int  # live particles
    emitters: int

    @classmethod
    def from_result(cls, result: bytes) -> StateChecksum:
        """The checksum from the digest pass's 24 bytes."""
        particles, emitters = np.frombuffer(result, "<u4", 2, 16)
        return cls(result[:16].hex(), int(particles), int(emitters))
