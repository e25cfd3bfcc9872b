"""The GPU checksum's float-free numpy twin: the same integer passes, for tests, `doctor`
and walls simulated in memory.

Mirrors shaders/checksum/ and include/digest.glsl step by step (see
cavesim/gpu/engine/checksum.py for the passes and why any changed word changes the digest);
`reference_levels` gives every level of the tree, as the GPU keeps them.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.digest.shape import (
    FOLD,
    WORDS_PER_GROUP,
    WORDS_PER_THREAD,
    WORKGROUP_SIZE,
    StateChecksum,
    group_count,
)
from cavesim.core.records import EMITTER_WORDS, PARTICLE_WORDS

INDEX_MIX = 0x9E3779B9  # a word is xor'ed with its index times this before it is mixed
_PERMUTE_CONSTANTS = (0x6A09E667, 0xBB67AE85, 0x3C6EF372, 0xA54FF53A)
_FOLD_IV = (0x510E527F, 0x9B05688C)
_DIGEST_IV = (0x1F83D9AB, 0x5BE0CD19, 0xCBBB9D5D, 0x629A292A)


def reference_checksum(particle_words: np.ndarray, emitter_words: np.ndarray,
                       seed: int) -> StateChecksum:
    """The checksum of a state given as the uint32 words of its two live streams."""
    particle_words, emitter_words = _streams(particle_words, emitter_words)
    particles = particle_words.size // PARTICLE_WORDS
    emitters = emitter_words.size // EMITTER_WORDS
    header = np.array([[seed & 0xFFFFFFFF, seed >> 32, particles, emitters]], dtype=np.uint32)
    state = _absorb(np.array([_DIGEST_IV], dtype=np.uint32), header)
    for item in reference_levels(particle_words, emitter_words)[2]:
        state = _absorb(state, item[None])
    digest = _permute(_permute(state))
    return StateChecksum(digest.astype("<u4").tobytes().hex(), particles, emitters)


def reference_levels(particle_words: np.ndarray, emitter_words: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tree under the digest: the sums (n, 2), fold 1's and fold 2's items (n, 4)."""
    particle_words, emitter_words = _streams(particle_words, emitter_words)
    sums = np.concatenate([reference_sums(particle_words), reference_sums(emitter_words)])
    items = np.zeros((len(sums), 4), dtype=np.uint32)
    items[:, :2] = sums
    level_1 = _fold(items, 1)
    return sums, level_1, _fold(level_1, 2)


def _streams(particle_words: np.ndarray, emitter_words: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    particle_words = np.asarray(particle_words, dtype=np.uint32).reshape(-1)
    emitter_words = np.asarray(emitter_words, dtype=np.uint32).reshape(-1)
    if particle_words.size % PARTICLE_WORDS or emitter_words.size % EMITTER_WORDS:
        raise ValueError(f"streams must be whole records of {PARTICLE_WORDS} and "
                         f"{EMITTER_WORDS} words, got {particle_words.size} and "
                         f"{emitter_words.size} words")
    return particle_words, emitter_words


def keyed_words(words: np.ndarray) -> np.ndarray:
    """Each word xor'ed with its index times INDEX_MIX: what the sums pass mixes."""
    words = np.asarray(words, dtype=np.uint32)
    index = np.arange(words.size, dtype=np.uint32)
    with np.errstate(over="ignore"):
        return words ^ (index * np.uint32(INDEX_MIX))


def reference_sums(words: np.ndarray) -> np.ndarray:
    """The sums pass over one stream: (invocations, 2) uint32, invocation by invocation."""
    words = np.asarray(words, dtype=np.uint32)
    h = keyed_words(words)
    with np.errstate(over="ignore"):
        lanes = np.stack([_fmix32(h), _fmix32(h + np.uint32(0x7F4A7C15))], axis=1)
    groups = group_count(words.size)
    padded = np.zeros((groups * WORDS_PER_GROUP, 2), dtype=np.uint32)
    padded[: words.size] = lanes
    # invocation t of group g reads words g·WORDS_PER_GROUP + k·WORKGROUP_SIZE + t
    by_invocation = padded.reshape(groups, WORDS_PER_THREAD, WORKGROUP_SIZE, 2)
    sums = by_invocation.sum(axis=1, dtype=np.uint64)
    return (sums & 0xFFFFFFFF).astype(np.uint32).reshape(-1, 2)


def _fold(items: np.ndarray, level: int) -> np.ndarray:
    """Fold pass `level`: chunk j of FOLD items absorbed in order (all j at once)."""
    count = len(items)
    chunks = -(-count // FOLD)
    state = np.empty((chunks, 4), dtype=np.uint32)
    state[:, 0], state[:, 1] = level, np.arange(chunks)
    state[:, 2:] = _FOLD_IV
    padded = np.zeros((chunks * FOLD, 4), dtype=np.uint32)
    padded[:count] = items
    padded = padded.reshape(chunks, FOLD, 4)
    live = (np.arange(chunks * FOLD) < count).reshape(chunks, FOLD, 1)
    for k in range(FOLD):
        state = np.where(live[:, k], _absorb(state, padded[:, k]), state)
    return state


def _absorb(state: np.ndarray, item: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        return _permute(state + item)


def _permute(state: np.ndarray) -> np.ndarray:
    """include/digest.glsl's permute on rows of 4 lanes."""
    s = [state[:, lane].copy() for lane in range(4)]
    with np.errstate(over="ignore"):
        for lane, constant in enumerate(_PERMUTE_CONSTANTS):
            s[lane] = _fmix32(s[lane] + s[lane - 1] + np.uint32(constant))
    return np.stack(s, axis=1)


def _fmix32(h: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        h = h ^ (h >> np.uint32(16))
        h = h * np.uint32(0x85EBCA6B)
        h = h ^ (h >> np.uint32(13))
        h = h * np.uint32(0xC2B2AE35)
        return h ^ (h >> np.uint32(16))
