"""A state whose checksum equals another's: why the checksum proves equality between honest
walls and nothing about who sent a state.

The checksum's sums pass adds, per invocation, a mix of each word xor'ed with a multiple
of its index (cavesim/core/digest/twin.py). Two words of one invocation that trade those
xor'ed values leave every sum, hence the digest, as it was; the state differs in two
particles. Nothing is searched for: any state has such twins.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.digest.shape import WORDS_PER_GROUP, WORKGROUP_SIZE
from cavesim.core.digest.twin import keyed_words
from cavesim.core.records import PARTICLE_WORDS


def colliding_particles(words: np.ndarray) -> np.ndarray:
    """Another particle stream (uint32 words) with the same checksum as `words`: the first
    pair of words WORKGROUP_SIZE apart in one work group's block (one invocation reads
    both) whose xor'ed values differ, traded. ValueError when there is no such pair."""
    words = np.asarray(words, dtype=np.uint32).reshape(-1)
    keyed = keyed_words(words)
    for i in range(words.size - WORKGROUP_SIZE):
        j = i + WORKGROUP_SIZE
        if keyed[i] != keyed[j] and i % WORDS_PER_GROUP < WORDS_PER_GROUP - WORKGROUP_SIZE:
            colliding = words.copy()
            colliding[i] = keyed[j] ^ (keyed[i] ^ words[i])
            colliding[j] = keyed[i] ^ (keyed[j] ^ words[j])
            return colliding
    raise ValueError(f"a stream of {words.size} words has no two differing words "
                     f"{WORKGROUP_SIZE} apart")


def changed_particles(words: np.ndarray, other: np.ndarray) -> list[int]:
    """The particle records in which two streams of words differ."""
    differ = np.flatnonzero(np.asarray(words) != np.asarray(other))
    return sorted({int(w) // PARTICLE_WORDS for w in differ})
