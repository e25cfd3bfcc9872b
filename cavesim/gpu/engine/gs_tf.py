"""The paper's engine path: geometry shader + transform feedback (`engine = "gs_tf"`).

After the emitter update (shared by both paths, `particle_system.py`) a frame is two
transform-feedback passes and a move:
  1. particle pass (shaders/particles/update.glsl): survivors of the front stream, moved,
     streamed out in input order into the back particle buffer;
  2. emission (emit.glsl): the updated emitters stream their new particles, in
     (batch, emitter, n) order, into a scratch buffer;
  3. splice (splice.glsl): the new particles move after the survivors; what does not fit
     the capacity is dropped, as transform feedback would drop it, and counted (`drops.py`).
Each transform-feedback pass is counted by a primitives query whose result lands in the
frame's counts buffer (`PrimitiveCounts`): on the GPU where the context has query buffer
objects, so the frame's only wait is the host's read of the live count (with the checksum's
digest); by the host, after a wait per count, elsewhere.
This is the reference the compute path (`compute.py`) is held to, byte for byte.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import moderngl
import numpy as np

from cavesim.core.emitters import EMIT_BATCH
from cavesim.core.records import EMITTER_VERTEX_FORMAT, PARTICLE_BYTES, PARTICLE_VERTEX_FORMAT
from cavesim.core.scene.model import Engine, Scene
from cavesim.gpu.engine.counter_buffer import stage_counts
from cavesim.gpu.engine.drops import DROPPED, LIVE
from cavesim.gpu.engine.emission import Emission
from cavesim.gpu.engine.pass_timers import PassTimers
from cavesim.gpu.engine.programs import (
    BLOCK_WORKGROUP_SIZE,
    emit_program,
    particle_update_program,
    splice_program,
)
from cavesim.gpu.engine.uniforms import write_uniforms
from cavesim.gpu.gl.fence import GpuFence
from cavesim.gpu.gl.primitive_counts import PrimitiveCounts

# The frame's counts buffer, as splice.glsl declares it: after LIVE and DROPPED, the
# passes' primitives at these byte offsets
SURVIVORS, GENERATED = 8, 12
FRAME_COUNTS = 5  # its storage-buffer binding (as in the compute path's streams.glsl)

BufferFactory = Callable[[str, int], moderngl.Buffer]


class GsTfPasses:
    """The particle pass and the emission of one frame, by transform feedback."""

    def __init__(self, ctx: moderngl.Context, scene: Scene,
                 particles: Sequence[moderngl.Buffer], emitters: Sequence[moderngl.Buffer],
                 bind_samplers: Callable[[moderngl.Program], None], buffer: BufferFactory,
                 fence: GpuFence, timers: PassTimers) -> None:
        self._ctx = ctx
        self._particles = particles
        self._timers = timers
        self._bind_samplers = bind_samplers
        self._buffer = buffer
        self._capacity = scene.capacity
        self._counts = buffer("gs_tf_counts", GENERATED + 4)
        self._counted = PrimitiveCounts(ctx, self._counts, fence)
        # the particle pass counts where its vertex stage may write storage
        self.program = particle_update_program(ctx, scene, stage_counts(Engine.GS_TF, ctx.info))
        self._update_vaos = [ctx.vertex_array(self.program, [(
            buffer, PARTICLE_VERTEX_FORMAT, "in_a", "in_b", "in_c")]) for buffer in particles]
        self._emitter_count = len(scene.emitters)
        if emitters:
            self._emit = emit_program(ctx, scene)
            self._emit_vaos = [ctx.vertex_array(self._emit, [(
                buffer, EMITTER_VERTEX_FORMAT, "in_state")]) for buffer in emitters]
            self._splice = splice_program(ctx)
            write_uniforms(self._splice, {"capacity": np.uint32(scene.capacity)})
            self._max_groups = int(ctx.info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0])
        self._emitted: moderngl.Buffer | None = None  # the emission's scratch, grown on need

    @property
    def counts_buffer(self) -> moderngl.Buffer:
        """The storage buffer holding the last frame's live and dropped counts (`drops.py`)."""
        return self._counts

    def advance(self, front: int, back: int, live: int, emission: Emission | None) -> None:
        """Survivors of the `live` front particles, then the new ones, into the back buffer.

        The new live count stays on the GPU, in `counts_buffer`.
        """
        if emission is None or emission.batches == 0:
            self._particle_pass(front, back, live, LIVE)
            self._counted.put(DROPPED, 0)  # nothing emitted: nothing to drop
            return
        self._particle_pass(front, back, live, SURVIVORS)
        with self._timers.segment("emitter_pass"):
            self._emission(back, emission)

    def particle_pass(self, front: int, back: int, live: int) -> None:
        """The particle pass alone (the benchmark times it)."""
        self._particle_pass(front, back, live, SURVIVORS)

    def _particle_pass(self, front: int, back: int, live: int, survivors_at: int) -> None:
        if live == 0:
            self._counted.put(survivors_at, 0)
            return
        self._bind_samplers(self.program)
        with self._timers.segment("particle_pass"), self._counted.counting(survivors_at):
            self._update_vaos[front].transform(self._particles[back], moderngl.POINTS,
                                               vertices=live)

    def _emission(self, back: int, emission: Emission) -> None:
        # The scratch holds every new particle up to the capacity: the ones past it could
        # never be kept. The query counts every generated particle, including those.
        bound = min(emission.batches * EMIT_BATCH * self._emitter_count, self._capacity)
        emitted = self._scratch(bound)
        write_uniforms(self._emit, {"random_transform": emission.random_transform.T})
        self._bind_samplers(self._emit)
        with self._counted.counting(GENERATED):
            self._emit_vaos[back].transform(emitted, moderngl.POINTS,
                                            vertices=self._emitter_count,
                                            instances=emission.batches)
        emitted.bind_to_storage_buffer(0)
        self._particles[back].bind_to_storage_buffer(1)
        self._counts.bind_to_storage_buffer(FRAME_COUNTS)
        self._ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)
        self._splice.run(min(-(-bound // BLOCK_WORKGROUP_SIZE), self._max_groups))
        # read next as storage (checksum, next frame), as vertices (the next particle pass,
        # rendering) and by buffer reads (snapshots, the live count)
        self._ctx.memory_barrier()

    def _scratch(self, particles: int) -> moderngl.Buffer:
        """The emission's scratch buffer, holding at least `particles` records."""
        held = 0 if self._emitted is None else self._emitted.size // PARTICLE_BYTES
        if held < particles:
            if self._emitted is not None:
                self._emitted.release()
            self._emitted = self._buffer("gs_tf_emitted", max(particles, min(
                2 * held, self._capacity)) * PARTICLE_BYTES)
        return self._emitted
