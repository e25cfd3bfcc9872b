"""Reading a particle system's state and loading one, on the GPU (`ParticleSystem`'s).

A state load (a snapshot, a test's setup) is staged in the back buffers, the scratch
between frames, and becomes current only on `commit_load`: a failed or partial load leaves
the current state untouched. A patch (a delta resync) is a load that starts as a copy of the
current state and replaces some records. Reads take the live records of the current state,
in stream order.
"""

from __future__ import annotations

import moderngl
import numpy as np

from cavesim.core.digest.shape import EMITTERS, PARTICLES, index_runs
from cavesim.core.emitters import EmitterTable
from cavesim.core.errors import StateError
from cavesim.core.records import EMITTER_BYTES, EMITTER_DTYPE, PARTICLE_BYTES, PARTICLE_DTYPE
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.checksum import GpuChecksum


class StateAccess:
    """The reads and loads of a `ParticleSystem`, which holds what they use: the attributes
    below, its checksum's `_state_checksum` and `_drop_tree`, `reseed` and `history_ring`."""

    ctx: moderngl.Context
    scene: Scene
    emitters: EmitterTable
    generation: int  # states made current so far
    _particle_buffers: list[moderngl.Buffer]
    _emitter_buffers: list[moderngl.Buffer]
    _current: int  # index of the front buffers
    _live: int | None
    _dropped: int | None
    _loading: int | None  # particles of the load staged in the back buffer
    _checksum: GpuChecksum
    live_count: int
    capacity: int

    def read_particle_chunk(self, first: int, count: int) -> bytes:
        """Records [first, first + count) of the live particle stream, as bytes."""
        if not (0 <= first and 0 <= count and first + count <= self.live_count):
            raise StateError(f"particle records [{first}, {first + count}) are not within the "
                             f"{self.live_count} live ones")
        if count == 0:  # GL cannot map an empty range
            return b""
        return self._particle_buffers[self._current].read(count * PARTICLE_BYTES,
                                                          first * PARTICLE_BYTES)

    def read_records(self, stream: int, indices: np.ndarray) -> bytes:
        """Records `indices` (ascending, live) of the current `stream` (PARTICLES or
        EMITTERS), as bytes in that order."""
        indices = np.asarray(indices, dtype=np.int64)
        live = self.live_count if stream == PARTICLES else len(self.emitters)
        if len(indices) and (indices[0] < 0 or indices[-1] >= live
                             or np.any(np.diff(indices) <= 0)):
            raise StateError(f"records must be ascending within the {live} live ones of "
                             f"stream {stream}, got {len(indices)} from {indices[0]} to "
                             f"{indices[-1]}")
        if stream == EMITTERS:
            return self.read_emitters()[indices].tobytes()
        return b"".join(self.read_particle_chunk(int(indices[first]), end - first)
                        for first, end in index_runs(indices))

    def read_particles(self) -> np.ndarray:
        """A copy of the live particle stream (PARTICLE_DTYPE), in stream order."""
        data = self.read_particle_chunk(0, self.live_count)
        return np.frombuffer(data, dtype=PARTICLE_DTYPE).copy()

    def read_emitters(self) -> np.ndarray:
        """A copy of the emitter stream (EMITTER_DTYPE)."""
        if not len(self.emitters):
            return np.zeros(0, dtype=EMITTER_DTYPE)
        data = self._emitter_buffers[self._current].read(len(self.emitters) * EMITTER_BYTES)
        return np.frombuffer(data, dtype=EMITTER_DTYPE).copy()

    def begin_load(self, count: int) -> None:
        """Start staging a particle stream of `count` records in the back buffer.

        The current state stays as it is until `commit_load`; a new `begin_load` or the next
        `step` drops what was staged.
        """
        if not 0 <= count <= self.capacity:
            raise StateError(f"a load of {count} particles does not fit the capacity "
                             f"{self.capacity}; allowed: 0 to {self.capacity}")
        self._loading = count
        self._drop_tree(1 - self._current)

    def begin_patch(self) -> None:
        """Start staging a copy of the current particle stream (copied on the GPU) in the
        back buffer, whose records `write_particle_chunk` may then replace; `commit_load`
        makes it current, as any load."""
        live = self.live_count
        self.begin_load(live)
        if live:
            self.ctx.copy_buffer(self._particle_buffers[1 - self._current],
                                 self._particle_buffers[self._current],
                                 size=live * PARTICLE_BYTES)
            # the copy is done before any record is written over it: on an NVIDIA H100
            # (driver 580) records written right after it were found overwritten by it
            self.ctx.finish()

    def write_particle_chunk(self, first: int, data: bytes) -> None:
        """Stage whole records [first, ...) of the stream that `begin_load` announced."""
        count, rest = divmod(len(data), PARTICLE_BYTES)
        if self._loading is None:
            raise StateError("write_particle_chunk needs a begin_load first")
        if rest or first < 0 or first + count > self._loading:
            raise StateError(f"a chunk of {len(data)} bytes at record {first} is not whole "
                             f"{PARTICLE_BYTES}-byte records within the {self._loading} loaded")
        if count:
            self._particle_buffers[1 - self._current].write(data, offset=first * PARTICLE_BYTES)
            self._drop_tree(1 - self._current)

    def commit_load(self, emitters: np.ndarray | None = None, seed: int | None = None,
                    digest: str | None = None) -> None:
        """Make the staged particles current, with `emitters` (default: the current ones)
        and `seed` (default: the scene's).

        With a `digest`, the staged state must have that checksum (`StateChecksum.digest`),
        else StateError and the current state stays as it was.
        """
        count, back = self._loading, 1 - self._current
        if count is None:
            raise StateError("commit_load needs a begin_load first")
        self._stage_emitters(back, emitters)
        seed = self.scene.seed if seed is None else seed
        if digest is not None \
                and (staged := self._state_checksum(back, count, seed).digest) != digest:
            self._loading = None
            raise StateError(f"the staged state's checksum {staged} is not the announced "
                             f"{digest}; the current state is kept")
        if seed != self.scene.seed:
            self.reseed(seed)
        self._current, self._live, self._loading = back, count, None
        self.generation += 1
        self._counts = self._counters.zeros(self._counted)  # a loaded state was not stepped

    def _stage_emitters(self, back: int, emitters: np.ndarray | None) -> None:
        count = len(self.emitters)
        if emitters is None:
            emitters = self.read_emitters()
        emitters = _checked_records(emitters, EMITTER_DTYPE, count, "emitters")
        if len(emitters) != count:
            raise StateError(f"emitters: expected {count} records, got {len(emitters)}")
        if count:
            self._emitter_buffers[back].write(emitters.tobytes())
            self._drop_tree(back)

    def restart(self, seed: int) -> None:
        """Back to the start state of a scene whose seed is `seed`: no particles, every
        emitter at rest (all zero, as a new system's are)."""
        self.begin_load(0)
        self.commit_load(np.zeros(len(self.emitters), EMITTER_DTYPE), seed)
        self.history_ring.clear()

    def write_particles(self, particles: np.ndarray) -> None:
        """Replace the live particle stream at once (a test's, a benchmark's or a fault's)."""
        particles = _checked_records(particles, PARTICLE_DTYPE, self.capacity, "particles")
        self.begin_load(len(particles))
        self.write_particle_chunk(0, particles.tobytes())
        self.commit_load()


def _checked_records(records: np.ndarray, dtype: np.dtype, limit: int, what: str) -> np.ndarray:
    records = np.asarray(records)
    if records.dtype != dtype or records.ndim != 1:
        raise StateError(f"{what}: expected a 1-D array of dtype {dtype}, "
                         f"got shape {records.shape} of dtype {records.dtype}")
    if len(records) > limit:
        raise StateError(f"{what}: {len(records)} records exceed the limit of {limit}")
    return np.ascontiguousarray(records)
