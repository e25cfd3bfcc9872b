"""Checksum of a node's live state, reduced on the GPU to a 128-bit digest read in 24 bytes.

Runs after a frame's passes. The digest covers the scene's 64-bit seed, both live counts
and every live word of both streams with its index; bytes past the counts are never read
(determinism rule 4). The passes (shaders/checksum/), integer arithmetic only, so every
GPU gives the same bits, and none with a shared-memory barrier (llvmpipe runs `barrier()`
as per-invocation coroutines):
  sums    one dispatch, the particle stream's groups, then the emitter stream's: each
          invocation sums over its 256 words two bijective mixes (fmix32) of
          `word XOR index·0x9E3779B9`;
  fold 1  invocation j absorbs sums [64j, 64j + 64) in order into a 128-bit state;
  fold 2  the same over fold 1's states;
  digest  one invocation absorbs (seed, counts), then fold 2's states, in order.
The shaders read the live counts from the `counts` buffer: the host writes them there
(`run(..., counts=...)`, no sync), or a GPU pass does and `run` sizes its dispatches on the
GPU (the `plan` pass writes glDispatchComputeIndirect's arguments). Either way the passes
and the digest are the same; `read` returns digest and counts at once.

The levels under the digest form a hash tree (cavesim/core/digest/shape.py): they stay in
their buffers until the next `run`, and `read_items` reads any of their items on demand
(desync forensics, delta resync), so a frame without a divergence reads none of them.
`keep_history` copies the fold-1 items into a ring slot on the GPU (a few KB per frame at
1M particles, no wait).

Why any single changed word changes the digest (for fixed counts, hence fixed sizes):
fmix32 is a bijection of 32-bit words, and so is XOR with a constant, so the changed
word's mix changes, and so does its invocation's sum (its other terms fixed, addition mod
2^32 is a bijection). `permute` is a bijection of 128-bit states (each of its steps
replaces one lane by a bijection of it for the other lanes fixed), so
`absorb(s, x) = permute(s + x)` is injective in x for s fixed and in s for x fixed. A fold
is a chain of absorbs: the absorb of the changed item gives another state, and every
later absorb and the final `permute∘permute` carry the difference to the output. That
output is one item of the next level, and so on to the digest. The seed is one item of the
digest's chain likewise. Order counts through the index in the first mix and the chain's
order; a change of a count changes the header item and the sizes, and is caught with
probability 1 - 2^-128 like any change of several words.
"""

from __future__ import annotations

import moderngl
import numpy as np

from cavesim.core.digest.history import HISTORY_FRAMES
from cavesim.core.digest.shape import ITEM_WORDS, StateChecksum, index_runs, plan
from cavesim.gpu.engine.programs import checksum_programs
from cavesim.gpu.gl.fence import GpuFence

COUNTS_BYTES = 8  # std430 { uint particles; uint emitters; }
RESULT_BYTES = 24  # std430 { uvec4 digest; uint particles; uint emitters; }
DISPATCH_BYTES = 12  # glDispatchComputeIndirect's x, y, z; `plan` writes three: sums,
# fold 1, fold 2
_SHADER_WRITES = moderngl.SHADER_STORAGE_BARRIER_BIT | moderngl.COMMAND_BARRIER_BIT


class GpuChecksum:
    """Reduces the live words of a state's buffers to one digest; one instance per context.

    `counts` is the GPU's copy of the live counts that the passes read (COUNTS_BYTES: uint
    particles, uint emitters); a compute pass may write it as a storage buffer, or
    `ctx.copy_buffer` into it, before `run()` without counts.
    """

    def __init__(self, ctx: moderngl.Context, max_particles: int, max_emitters: int,
                 fence: GpuFence) -> None:
        self.ctx = ctx
        self.fence = fence  # the reads wait on it, not inside the driver
        self.max_particles, self.max_emitters = max_particles, max_emitters
        self._programs = checksum_programs(ctx)
        sums, level_1, level_2 = plan(max_particles, max_emitters).items
        self.counts = ctx.buffer(reserve=COUNTS_BYTES)
        self.result = ctx.buffer(reserve=RESULT_BYTES)
        self._dispatches = ctx.buffer(reserve=3 * DISPATCH_BYTES)
        self._sums = ctx.buffer(reserve=max(sums * 8, 4))
        self._folds = [ctx.buffer(reserve=max(n, 1) * 16) for n in (level_1, level_2)]
        self._slot_rows = max(level_1, 1)  # a history slot: fold 1's items at capacity
        self._history = ctx.buffer(reserve=HISTORY_FRAMES * self._slot_rows * 16)
        self._seed: int | None = None

    def run(self, particles: moderngl.Buffer, emitters: moderngl.Buffer | None, seed: int,
            counts: tuple[int, int] | None = None) -> None:
        """Queue the passes over `particles` and `emitters` (None: a scene without emitters).

        With `counts` (particles, emitters) the host writes them into `counts` and sizes the
        dispatches; without, the counts already in `counts` decide, on the GPU. Nothing waits.
        """
        self._write_seed(seed)
        self.ctx.memory_barrier(_SHADER_WRITES)  # a compute pass's writes: streams, counts
        self.counts.bind_to_storage_buffer(2)
        if counts is None:
            groups: tuple[int | None, ...] = (None,) * 3  # the plan's, on the GPU
            self._dispatches.bind_to_storage_buffer(1)
            self._programs["plan"].run(1)
            self.ctx.memory_barrier(_SHADER_WRITES)
        else:
            self._write_counts(*counts)
            sizes = plan(*counts)
            groups = (sizes.sums_groups, sizes.fold_groups(1), sizes.fold_groups(2))
        particles.bind_to_storage_buffer(0)
        (emitters or particles).bind_to_storage_buffer(3)
        self._sums.bind_to_storage_buffer(1)
        self._dispatch(self._programs["sums"], groups, 0)
        for level, source in ((1, self._sums), (2, self._folds[0])):
            self.ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)
            source.bind_to_storage_buffer(0)
            self._folds[level - 1].bind_to_storage_buffer(1)
            self._dispatch(self._programs[f"fold_{level}"], groups, level)
        self.ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)
        self._folds[1].bind_to_storage_buffer(0)
        self.result.bind_to_storage_buffer(1)
        self._programs["digest"].run(1)

    def read(self) -> StateChecksum:
        """The last `run`'s digest and the counts it covered: one 24-byte read (waits)."""
        self.ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        self.fence.wait()
        return StateChecksum.from_result(self.result.read(RESULT_BYTES))

    def read_items(self, level: int, indices: np.ndarray) -> np.ndarray:
        """Items `indices` (ascending) of tree level `level` (0: the sums, 1, 2) as the last
        `run` left them: (n, ITEM_WORDS[level]) uint32 (waits)."""
        self.ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        return _read_rows((self._sums, *self._folds)[level], ITEM_WORDS[level], indices)

    def keep_history(self, slot: int) -> None:
        """Copy the last `run`'s fold-1 items into history slot `slot` (0 to HISTORY_FRAMES -
        1), GPU to GPU: nothing waits."""
        self.ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        self.ctx.copy_buffer(self._history, self._folds[0], size=self._slot_rows * 16,
                             write_offset=slot * self._slot_rows * 16)

    def read_history(self, slot: int, indices: np.ndarray) -> np.ndarray:
        """Fold-1 items `indices` (ascending) kept in history slot `slot` (waits)."""
        if len(indices) and indices[-1] >= self._slot_rows:
            raise ValueError(f"fold-1 items up to {indices[-1]} asked; the history holds "
                             f"{self._slot_rows} per frame")
        return _read_rows(self._history, ITEM_WORDS[1], np.asarray(indices)
                          + slot * self._slot_rows)

    def state(self, particles: moderngl.Buffer, particle_count: int,
              emitters: moderngl.Buffer | None, emitter_count: int, seed: int) -> StateChecksum:
        """The checksum of a state whose live counts the host knows."""
        self.run(particles, emitters, seed, (particle_count, emitter_count))
        return self.read()

    def _write_counts(self, particles: int, emitters: int) -> None:
        if not (0 <= particles <= self.max_particles and 0 <= emitters <= self.max_emitters):
            raise ValueError(f"counts must be within (0..{self.max_particles}, "
                             f"0..{self.max_emitters}), got {particles=}, {emitters=}")
        self.counts.write(np.array([particles, emitters], "<u4").tobytes())

    def _write_seed(self, seed: int) -> None:
        if seed != self._seed:
            if not 0 <= seed < 2**64:
                raise ValueError(f"seed must be within 0..2**64 - 1, got {seed=}")
            self._programs["digest"]["seed"].value = (seed & 0xFFFFFFFF, seed >> 32)
            self._seed = seed

    def _dispatch(self, program: moderngl.ComputeShader, groups: tuple[int | None, ...],
                  k: int) -> None:
        """Run `program` as dispatch `k`: on groups[k] groups, or as the plan says if None."""
        if groups[k] is None:
            program.run_indirect(self._dispatches, k * DISPATCH_BYTES)
        elif groups[k]:
            program.run(groups[k])

    def release(self) -> None:
        for buffer in (self.counts, self.result, self._dispatches, self._sums, *self._folds,
                       self._history):
            buffer.release()


def _read_rows(buffer: moderngl.Buffer, words: int, indices: np.ndarray) -> np.ndarray:
    """Rows `indices` (ascending) of `words` uint32 each: one read per run of consecutive
    rows, as a block's children and a history's blocks come."""
    indices = np.asarray(indices, dtype=np.int64)
    rows = np.empty((len(indices), words), dtype=np.uint32)
    for first, end in index_runs(indices):
        data = buffer.read((end - first) * words * 4, int(indices[first]) * words * 4)
        rows[first:end] = np.frombuffer(data, "<u4").reshape(-1, words)
    return rows
