"""The emitter update, the first pass of every frame on both engine paths.

A transform-feedback pass over the emitter stream (shaders/particles/emitter_update.glsl):
each emitter adds rate·dt to its accumulator and takes the whole part as this frame's count,
capped by the host's bound (`EmitterTable.max_emit`). The counts stay on the GPU, in the
back emitter buffer; the host knows only the bound, which sizes the emission that follows
(GS/TF: instances of the emit draw; compute: segments of the append dispatch).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.core.emitters import EMIT_BATCH, FIXED_ROWS, FRAME_ROWS, EmitterTable
from cavesim.core.frame import FrameInput
from cavesim.core.records import EMITTER_VERTEX_FORMAT
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.programs import emitter_update_program
from cavesim.gpu.engine.uniforms import write_uniforms


@dataclass(frozen=True)
class Emission:
    """This frame's emission as the host knows it before the GPU has counted."""

    batches: int  # EMIT_BATCH-particle batches per emitter that can hold a new particle
    random_transform: np.ndarray  # the frame's 3x3 random-texture matrix


class EmitterUpdate:
    """The emitter stream's pass: front emitter buffer in, back emitter buffer out."""

    def __init__(self, ctx: moderngl.Context, scene: Scene, table: EmitterTable,
                 table_texture: moderngl.Texture, buffers: Sequence[moderngl.Buffer],
                 bind_samplers: Callable[[moderngl.Program], None]) -> None:
        self.table = table
        self._capacity = scene.capacity
        self._texture = table_texture
        self._buffers = buffers
        self._bind_samplers = bind_samplers
        self._program = emitter_update_program(ctx, scene)
        self._vaos = [ctx.vertex_array(self._program, [(buffer, EMITTER_VERTEX_FORMAT,
                                                        "in_state")]) for buffer in buffers]

    def run(self, front: int, back: int, frame: FrameInput, rotor) -> Emission:
        """Update the emitters for `frame` (and the helicopter's `rotor`, if any)."""
        factors = None if rotor is None else rotor.rate_factors
        max_emit = self.table.max_emit(frame.dt, self._capacity, factors)
        rows = self.table.frame_rows(max_emit, factors, None if rotor is None else rotor.origins)
        self._texture.write(rows.tobytes(), viewport=(0, FIXED_ROWS, len(self.table),
                                                      FRAME_ROWS))
        write_uniforms(self._program, {"dt": frame.dt})
        self._bind_samplers(self._program)
        self._vaos[front].transform(self._buffers[back], moderngl.POINTS,
                                    vertices=len(self.table))
        return Emission(math.ceil(int(max_emit.max()) / EMIT_BATCH), frame.random_transform)
