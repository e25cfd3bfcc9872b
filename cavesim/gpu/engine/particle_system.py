"""The particle system of one wall node on one GL context.

A frame (`step`) updates the emitter stream (`emission.py`), then steps the particle stream
into the back buffers by the scene's engine path, then swaps:
  - gs_tf (`gs_tf.py`, the paper's method): a transform-feedback particle pass streams out
    the survivors in input order, and the emitters' new particles go after them;
  - compute (`compute.py`): an in-place compute update, an ordered stream compaction and an
    append, giving the same bytes.
Both leave the new live count on the GPU: the frame waits once, when the checksum reads it
back with the digest (GS/TF also once per count where the context has no query buffers).
The frame's counters (cavesim/core/counters.py) go into one buffer (`counter_buffer.py`):
cleared before the passes, the drops copied in after them, read after the checksum's wait.
Only the scene's features are compiled in and allocated (see `programs.py`). The capacity
is checked against the context's limits (`capacity.py`) before anything is allocated.

Reading the state and loading one (a snapshot, a patch, a test's setup) are
`state_access.py`'s.

The checksum's hash tree of the current state (cavesim/core/digest/shape.py) can be read
item by item (`tree_items`), and `keep_history` keeps each frame's fold-1 items in a ring
on the GPU (`history` reads them): a node answers the master's forensics and a resyncing
node's delta requests from these.
"""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np

from cavesim.core.counters import Counts
from cavesim.core.digest.history import HistoryEntry, HistoryRing
from cavesim.core.digest.shape import StateChecksum
from cavesim.core.emitters import FIXED_ROWS, TABLE_ROWS, EmitterTable
from cavesim.core.features.feature import FrameState, Texture
from cavesim.core.features.registry import features_of
from cavesim.core.fields.snapshot_time import FIRST_SNAPSHOT
from cavesim.core.frame import FrameInput
from cavesim.core.helicopter.inputs import RotorInputs
from cavesim.core.random_texture import random_words
from cavesim.core.records import (
    EMITTER_BYTES,
    PARTICLE_BYTES,
)
from cavesim.core.scene.model import ENGINE_PATHS, Engine, Scene
from cavesim.core.scene_frame import NOTHING_MOVES, SceneFrame
from cavesim.gpu.engine.capacity import PARTICLE_BUFFERS, capacity_limits
from cavesim.gpu.engine.checksum import GpuChecksum
from cavesim.gpu.engine.compute import ComputePasses
from cavesim.gpu.engine.counter_buffer import CounterBuffer, counted_here
from cavesim.gpu.engine.emission import EmitterUpdate
from cavesim.gpu.engine.feature_resources import FeatureResources
from cavesim.gpu.engine.gs_tf import GsTfPasses
from cavesim.gpu.engine.pass_timers import PassTimers
from cavesim.gpu.engine.state_access import StateAccess
from cavesim.gpu.engine.uniforms import write_uniforms
from cavesim.gpu.gl.fence import GpuFence

RANDOM_UNIT, EMITTER_UNIT, FIRST_FEATURE_UNIT = 0, 1, 2  # a feature's textures from the third


class ParticleSystem(StateAccess):
    """Emitter and particle streams of one scene, stepped frame by frame on the GPU."""

    def __init__(self, ctx: moderngl.Context, scene: Scene) -> None:
        if scene.engine not in ENGINE_PATHS:
            raise ValueError(f"a system steps with one of {', '.join(ENGINE_PATHS)}, not "
                             f"{scene.engine!r}: probe `auto` first (engine_probe.py)")
        limits = capacity_limits(ctx.info)
        limits.check(scene.capacity)
        self.ctx = ctx
        self.scene = scene
        self.emitters = EmitterTable.from_scene(scene)
        self.resources: dict[str, moderngl.Buffer | moderngl.Texture | moderngl.Texture3D] = {}
        self._live: int | None = 0  # None: the last frame's count is still on the GPU
        self._counts: Counts | None = {}  # likewise: the last frame's counters
        self._current = 0  # index of the front buffers
        self.generation = 0  # states made current so far: a drawing of one holds until the next
        self._loading: int | None = None  # particles of the load staged in the back buffer
        # the buffers whose checksum tree the GPU holds, and their checksum
        self._tree: tuple[int, StateChecksum] | None = None
        self.history_ring = HistoryRing()
        self.fence = GpuFence(ctx)  # every read of the frame's results waits on it
        self.timers = PassTimers(ctx)  # the GPU time of the frame's passes
        self._particle_buffers = [self._buffer(f"particles_{i}", scene.capacity * PARTICLE_BYTES)
                                  for i in range(PARTICLE_BUFFERS)]
        if (error := ctx.error) != "GL_NO_ERROR":  # GL_OUT_OF_MEMORY: no GL limit foretells it
            self.release()
            raise limits.allocation_error(scene.capacity, error)
        # the random texture's words, where emission or a feature draws from it
        self.random_words: np.ndarray | None = None
        self._counters = CounterBuffer(ctx, scene, self._buffer)
        self.rotor_inputs = RotorInputs(scene) if scene.helicopter is not None else None
        if len(self.emitters) or any(f.draws_random for f in features_of(scene)):
            self._random_texture()
        self.features = FeatureResources(ctx, scene, self.random_words, self._texture,
                                         FIRST_FEATURE_UNIT)
        self._emitter_buffers: list[moderngl.Buffer] = []
        self._emitter_update = self._build_emission() if len(self.emitters) else None
        self._passes = self._passes_for(scene.engine)
        self._checksum = GpuChecksum(ctx, scene.capacity, len(self.emitters), self.fence)
        self.restart(scene.seed)  # GL leaves a new buffer's content undefined: zero it

    # -- construction -----------------------------------------------------------------

    def _passes_for(self, engine: Engine) -> ComputePasses | GsTfPasses:
        """The particle passes of an engine path, over this system's buffers."""
        self._counted = counted_here(self.scene, engine, self.ctx.info)
        if engine is Engine.COMPUTE:
            passes = ComputePasses(self.ctx, self.scene, self._particle_buffers,
                                   self._emitter_buffers, self._bind_samplers, self._buffer,
                                   self.timers)
        else:
            passes = GsTfPasses(self.ctx, self.scene, self._particle_buffers,
                                self._emitter_buffers, self._bind_samplers, self._buffer,
                                self.fence, self.timers)
        write_uniforms(passes.program, self.features.uniforms(self.scene))
        return passes

    def use_engine(self, engine: Engine) -> None:
        """Step with `engine` from now on, the state kept (both paths read and write the
        same buffers, and give the same bytes). Its programs are compiled now."""
        if engine is self.engine:
            return
        live, counts = self.live_count, self.counters()  # the old path's, on the GPU
        self.scene = dataclasses.replace(self.scene, engine=engine)
        self._passes = self._passes_for(engine)
        self._live, self._counts = live, counts

    def _buffer(self, name: str, size: int) -> moderngl.Buffer:
        buffer = self.ctx.buffer(reserve=max(size, 4))  # GL has no empty buffers
        self.resources[name] = buffer
        return buffer

    def _texture(self, name: str, texture: Texture) -> moderngl.Texture | moderngl.Texture3D:
        """A texture of `texture.texels`, sampled by texelFetch (or filtered, `linear`)."""
        make = self.ctx.texture3d if len(texture.size) == 3 else self.ctx.texture
        made = make(texture.size, texture.components, texture.texels.tobytes(),
                    dtype=texture.dtype)
        made.filter = (moderngl.LINEAR, moderngl.LINEAR) if texture.linear else (
            moderngl.NEAREST, moderngl.NEAREST)
        made.repeat_x = made.repeat_y = False
        if len(texture.size) == 3:
            made.repeat_z = False
        self.resources[name] = made
        return made

    def _bind_samplers(self, program) -> None:
        for name, unit in (("random_texture", RANDOM_UNIT), ("emitter_table", EMITTER_UNIT),
                           *self.features.units.items()):
            if name in self.resources:
                self.resources[name].use(unit)
                if (sampler := program.get(name, None)) is not None:
                    sampler.value = unit

    def _random_texture(self) -> None:
        """The texture emission and the features that draw from it read (determinism rule 2)."""
        size = self.scene.random_texture_size
        self.random_words = random_words(self.scene.seed, size)
        random = self.ctx.texture((size, size), 4, self.random_words.tobytes(), dtype="u4")
        random.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.resources["random_texture"] = random

    def _build_emission(self) -> EmitterUpdate:
        scene, count = self.scene, len(self.emitters)
        table = self.ctx.texture((count, TABLE_ROWS), 4, dtype="u4")
        table.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.resources["emitter_table"] = table
        self._write_fixed_rows()
        self._emitter_buffers += [self._buffer(f"emitters_{i}", count * EMITTER_BYTES)
                                  for i in range(2)]
        return EmitterUpdate(self.ctx, scene, self.emitters, table, self._emitter_buffers,
                             self._bind_samplers)

    def _write_fixed_rows(self) -> None:
        self.resources["emitter_table"].write(
            self.emitters.fixed_rows().tobytes(), viewport=(0, 0, len(self.emitters), FIXED_ROWS))

    # -- the frame ----------------------------------------------------------------------

    @property
    def particle_program(self) -> moderngl.Program | moderngl.ComputeShader:
        """The particle pass's program (its uniforms show what the scene compiled in)."""
        return self._passes.program

    @property
    def engine(self) -> Engine:
        """The engine path that steps the particles (the scene's `[simulation] engine`)."""
        return self.scene.engine

    @property
    def front_particle_buffer_name(self) -> str:
        """Name (in `resources`) of the buffer holding the current particle stream."""
        return f"particles_{self._current}"

    @property
    def live_count(self) -> int:
        """Live particles; after a frame, the first call reads them back (waits)."""
        if self._live is None:
            self.fence.wait()  # the frame's passes left it in their counts buffer
            self._live = int(np.frombuffer(self._passes.counts_buffer.read(4), "<u4")[0])
        return self._live

    @property
    def capacity(self) -> int:
        return self.scene.capacity

    def step(self, frame: FrameInput, scene: SceneFrame = NOTHING_MOVES) -> None:
        """Advance one frame with exactly the inputs every other node gets.

        `scene` is the frame's scene state (its driver's); a helicopter scene's rotor is there.
        """
        rotor = self.rotor_inputs.read(scene) if self.rotor_inputs is not None else None
        live = self.live_count
        front, back = self._current, 1 - self._current
        self._loading = self._tree = None  # the passes overwrite the back buffers
        emission = None
        if self._emitter_update is not None:
            with self.timers.segment("emitter_pass"):
                emission = self._emitter_update.run(front, back, frame, rotor)
        state = FrameState(frame, rotor, scene.field_time or FIRST_SNAPSHOT)
        write_uniforms(self._passes.program, {
            "dt": frame.dt, **self.features.frame_uniforms(self.scene, state)})
        self._counters.start_frame()
        self._passes.advance(front, back, live, emission)
        self._counters.copy_passes_counts(self._passes.counts_buffer)
        self._live = self._counts = None  # the frame's counts are on the GPU
        self._current = back
        self.generation += 1

    def counters(self) -> Counts:
        """The last frame's counters by name (cavesim/core/counters.py): the rows this scene
        counts on this engine path and context (`counter_buffer.counted_here`); a row missing
        is not counted here. Each 0 after a load. Read them after `checksum()`, whose wait
        they share; before, they wait for the GPU themselves."""
        if self._counts is None:
            if self._live is None:
                self.fence.wait()
            self._counts = self._counters.read(self._counted)
        return dict(self._counts)

    def dropped(self) -> int:
        """New particles the last frame dropped because the capacity was full: its
        `capacity_drops` counter (0 after a load, and in a scene without emitters)."""
        return self.counters().get("capacity_drops", (0,))[0]

    def bench_particle_pass(self, dt: np.float32) -> None:
        """The engine path's particle pass alone on the live stream, waited for (what
        `cavesim bench` times as "update"). Nothing is swapped; the compute path steps the
        front buffer in place, so afterwards the state is only good for more timing."""
        write_uniforms(self._passes.program, {"dt": dt})
        self._tree = None
        self._passes.particle_pass(self._current, 1 - self._current, self.live_count)
        self.ctx.finish()

    def reseed(self, seed: int) -> None:
        """Rebuild what the scene's seed decides: the random texture and emitter bases.

        A node started with a wrong seed heals this way when it loads a snapshot.
        """
        self.scene = dataclasses.replace(self.scene, seed=seed)
        self._tree = None
        self.emitters = EmitterTable.from_scene(self.scene)
        if "random_texture" in self.resources:
            self.random_words = random_words(seed, self.scene.random_texture_size)
            self.resources["random_texture"].write(self.random_words.tobytes())
            write_uniforms(self._passes.program,
                           self.features.reseed(self.scene, self.random_words))
        if not len(self.emitters):
            return
        self._emitter_update.table = self.emitters
        self._write_fixed_rows()

    def release(self) -> None:
        """Free the GPU buffers and textures now instead of at garbage collection."""
        for resource in self.resources.values():
            resource.release()
        self.resources.clear()

    # -- state ----------------------------------------------------------------------------

    def checksum(self) -> StateChecksum:
        """Digest of the live particle and emitter streams, computed on the GPU. After a
        frame the live count is still on the GPU: the checksum takes it from there, and its
        one 24-byte read brings back the digest and the count together (the
        frame's only wait)."""
        if self._live is not None:
            return self._state_checksum(self._current, self._live, self.scene.seed)
        counts = self._checksum.counts
        self.ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)  # the frame's count
        self.ctx.copy_buffer(counts, self._passes.counts_buffer, size=4)
        counts.write(np.array([len(self.emitters)], "<u4").tobytes(), offset=4)
        emitters = self._emitter_buffers[self._current] if len(self.emitters) else None
        with self.timers.segment("checksum_pass"):
            self._checksum.run(self._particle_buffers[self._current], emitters, self.scene.seed)
        state = self._checksum.read()
        self._live, self._tree = state.particles, (self._current, state)
        return state

    def _state_checksum(self, index: int, particles: int, seed: int) -> StateChecksum:
        emitters = self._emitter_buffers[index] if len(self.emitters) else None
        with self.timers.segment("checksum_pass"):
            self._checksum.run(self._particle_buffers[index], emitters, seed,
                               (particles, len(self.emitters)))
        state = self._checksum.read()
        self._tree = (index, state) if seed == self.scene.seed else None
        return state

    # -- the checksum's tree ----------------------------------------------------------------

    def tree_state(self) -> tuple[int, int, int]:
        """(seed, live particles, emitters) of the current state, whose tree the GPU then
        holds."""
        state = self._current_tree()
        return self.scene.seed, state.particles, state.emitters

    def tree_items(self, level: int, indices: np.ndarray) -> np.ndarray:
        """Items `indices` (ascending) of level `level` (0: the sums, 1, 2) of the current
        state's checksum tree, (n, ITEM_WORDS[level]) uint32; the checksum runs first if the
        GPU holds another state's tree."""
        self._current_tree()
        return self._checksum.read_items(level, indices)

    def keep_history(self, frame: int) -> None:
        """Keep the current state's fold-1 items as frame `frame`'s in the history ring (a
        copy on the GPU, no wait)."""
        state = self._current_tree()
        slot = self.history_ring.keep(frame, state.particles, state.emitters)
        self._checksum.keep_history(slot)

    def history(self, indices: np.ndarray, up_to: int) -> list[tuple[HistoryEntry, np.ndarray]]:
        """Fold-1 items `indices` of every frame the ring holds up to `up_to`, oldest first."""
        return [(entry, self._checksum.read_history(entry.slot, indices))
                for entry in self.history_ring.up_to(up_to)]

    def _drop_tree(self, index: int) -> None:
        """The buffers `index` are being written: the GPU's tree is no longer theirs."""
        if self._tree is not None and self._tree[0] == index:
            self._tree = None

    def _current_tree(self) -> StateChecksum:
        """The current state's checksum, run again if the GPU's tree is another state's."""
        if self._tree is not None and self._tree[0] == self._current:
            return self._tree[1]
        return self.checksum()
