"""Checksum of a node's live state, computed on the GPU (no full read-back per frame).

The compute shader reduces each buffer's live words to one pair of sums per invocation
(313 KB for a million particles);
the host hashes those sums with the live counts and the scene's seed into one digest
(BLAKE2b-128): a node with the wrong seed differs from frame 1, and a snapshot's seed is
covered by the checksum the master names for it. Only the live range is hashed
(determinism rule 4): bytes past the count were never written.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.gpu.engine.programs import (
    CHECKSUM_WORDS_PER_THREAD,
    CHECKSUM_WORKGROUP_SIZE,
    checksum_program,
)

WORDS_PER_GROUP = CHECKSUM_WORKGROUP_SIZE * CHECKSUM_WORDS_PER_THREAD
PARTIAL_BYTES = 8  # two uint32 sums per invocation
GROUP_BYTES = CHECKSUM_WORKGROUP_SIZE * PARTIAL_BYTES


def group_count(words: int) -> int:
    """Work groups of the one dispatch that sums `words` words."""
    return -(-words // WORDS_PER_GROUP)


@dataclass(frozen=True)
class StateChecksum:
    digest: str  # 32 hex digits over both streams, their order and the live counts
    particles: int  # live particles
    emitters: int


class GpuChecksum:
    """Hashes the live words of GPU buffers; one instance per context."""

    def __init__(self, ctx: moderngl.Context, max_words: int) -> None:
        self._program = checksum_program(ctx)
        groups = max(1, group_count(max_words))
        self._partials = ctx.buffer(reserve=groups * GROUP_BYTES)

    def buffer_sums(self, buffer: moderngl.Buffer, word_count: int) -> bytes:
        """Per-invocation sums of the first `word_count` words of `buffer` (empty when 0)."""
        if word_count == 0:
            return b""
        groups = group_count(word_count)
        buffer.bind_to_storage_buffer(0)
        self._partials.bind_to_storage_buffer(1)
        self._program["word_count"].value = word_count
        self._program.run(groups)
        return self._partials.read(groups * GROUP_BYTES)

    def state(self, particles: moderngl.Buffer, particle_words: int, particle_count: int,
              emitters: moderngl.Buffer | None, emitter_words: int,
              emitter_count: int, seed: int) -> StateChecksum:
        """The digest of a node's state: both streams' live words, both counts, the seed."""
        digest = hashlib.blake2b(digest_size=16)
        digest.update(np.array([seed, particle_count, emitter_count], dtype="<u8").tobytes())
        digest.update(self.buffer_sums(particles, particle_words))
        if emitters is not None:
            digest.update(self.buffer_sums(emitters, emitter_words))
        return StateChecksum(digest.hexdigest(), particle_count, emitter_count)


def reference_sums(words: np.ndarray) -> bytes:
    """The shader's per-invocation sums computed with numpy, for tests of the GPU checksum."""
    words = np.asarray(words, dtype=np.uint32)
    index = np.arange(words.size, dtype=np.uint32)
    h = words ^ (index * np.uint32(0x9E3779B9))
    lanes = np.stack([_fmix32(h), _fmix32(h + np.uint32(0x7F4A7C15))], axis=1)
    groups = group_count(words.size)
    padded = np.zeros((groups * WORDS_PER_GROUP, 2), dtype=np.uint32)
    padded[: words.size] = lanes
    # invocation t of group g reads words g·WORDS_PER_GROUP + k·WORKGROUP_SIZE + t
    by_invocation = padded.reshape(groups, CHECKSUM_WORDS_PER_THREAD, CHECKSUM_WORKGROUP_SIZE, 2)
    sums = by_invocation.sum(axis=1, dtype=np.uint64)
    return (sums & 0xFFFFFFFF).astype("<u4").tobytes()


def _fmix32(h: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        h = h ^ (h >> np.uint32(16))
        h = h * np.uint32(0x85EBCA6B)
        h = h ^ (h >> np.uint32(13))
        h = h * np.uint32(0xC2B2AE35)
        return h ^ (h >> np.uint32(16))
