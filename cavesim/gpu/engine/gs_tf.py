"""The paper's engine path: geometry shader + transform feedback (`engine = "gs_tf"`).

After the emitter update (shared by both paths, `particle_system.py`) a frame is two
transform-feedback passes into the back particle buffer:
  1. particle pass (shaders/particles/update.glsl): survivors of the front stream, moved,
     streamed out in input order;
  2. emission (emit.glsl): the updated emitters append their new particles after the
     survivors, in (batch, emitter, n) order; what does not fit the capacity is dropped.
Transform feedback's primitives queries tell the host both counts: two waits per frame.
This is the reference the compute path (`compute.py`) is held to, byte for byte.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import moderngl

from cavesim.core.records import EMITTER_VERTEX_FORMAT, PARTICLE_BYTES, PARTICLE_VERTEX_FORMAT
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.emission import Emission
from cavesim.gpu.engine.pass_timers import PassTimers
from cavesim.gpu.engine.programs import emit_program, particle_update_program
from cavesim.gpu.engine.uniforms import write_uniforms
from cavesim.gpu.gl.fence import GpuFence


class GsTfPasses:
    """The particle pass and the emission of one frame, by transform feedback."""

    def __init__(self, ctx: moderngl.Context, scene: Scene,
                 particles: Sequence[moderngl.Buffer], emitters: Sequence[moderngl.Buffer],
                 bind_samplers: Callable[[moderngl.Program], None], fence: GpuFence,
                 timers: PassTimers) -> None:
        self._particles = particles
        self._fence, self._timers = fence, timers
        self._bind_samplers = bind_samplers
        self._capacity = scene.capacity
        self._query = ctx.query(primitives=True)
        self.program = particle_update_program(ctx, scene)
        self._update_vaos = [ctx.vertex_array(self.program, [(
            buffer, PARTICLE_VERTEX_FORMAT, "in_a", "in_b", "in_c")]) for buffer in particles]
        self._emit = emit_program(ctx, scene) if emitters else None
        self._emit_vaos = [ctx.vertex_array(self._emit, [(
            buffer, EMITTER_VERTEX_FORMAT, "in_state")]) for buffer in emitters]
        self._emitter_count = len(scene.emitters)

    def advance(self, front: int, back: int, live: int, emission: Emission | None) -> int:
        """Survivors of the `live` front particles, then the new ones, into the back buffer;
        returns the new live count."""
        survivors = self.particle_pass(front, back, live)
        if emission is None or emission.batches == 0 or survivors >= self._capacity:
            return survivors
        return survivors + self._emission(back, survivors, emission)

    def particle_pass(self, front: int, back: int, live: int) -> int:
        """The particle pass alone (the benchmark times it): returns the survivors."""
        if live == 0:
            return 0
        self._bind_samplers(self.program)
        with self._timers.segment("particle_pass"), self._query:
            self._update_vaos[front].transform(self._particles[back], moderngl.POINTS,
                                               vertices=live)
        self._fence.wait()  # the emission's offset is the survivors' count
        return self._query.primitives

    def _emission(self, back: int, survivors: int, emission: Emission) -> int:
        write_uniforms(self._emit, {"random_transform": emission.random_transform.T})
        self._bind_samplers(self._emit)
        # Transform feedback records only what fits after `buffer_offset`; the query counts
        # every generated particle, including the ones dropped (DESIGN: live = min(...)).
        with self._timers.segment("emitter_pass"), self._query:
            self._emit_vaos[back].transform(self._particles[back], moderngl.POINTS,
                                            vertices=self._emitter_count,
                                            instances=emission.batches,
                                            buffer_offset=survivors * PARTICLE_BYTES)
        self._fence.wait()
        return min(self._query.primitives, self._capacity - survivors)
