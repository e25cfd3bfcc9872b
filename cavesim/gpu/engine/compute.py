"""The compute engine path (`engine = "compute"`): the GS/TF frame's bytes, by compute shaders.

After the emitter update (shared with GS/TF, `emission.py`) four dispatches, each reading
what the one before wrote (a storage barrier between them):
  1. update_blocks.glsl: every live particle steps in place in the front buffer
     (`step_particle`, the GS/TF arithmetic); one invocation per block of 32 particles
     writes a bit mask of its survivors;
  2. scan.glsl: one work group turns [survivors per block | new particles per emission
     segment] into exclusive prefix sums, saturated at the capacity; the total is the new
     live count, left in a small storage buffer;
  3. compact.glsl: each block copies its survivors, in order, to their offsets in the back
     buffer;
  4. append.glsl: each emission segment (batch, emitter) spawns its particles at its offset,
     the records at or past the capacity dropped (the scan counted them: `drops.py`).
The order is the one transform feedback writes, and no step uses an unordered atomic
(DESIGN, determinism rule 3), so both paths hold the same bytes on one driver
(tests/gpu/test_engine_paths.py). The dispatches run with denormals flushed, as llvmpipe's
draws run (`cavesim.gpu.gl.denormals`); a driver on which they still differ is named in
the log when the path is built. Dispatch sizes come from what the host knows: the previous
live count and the emission's bound. The counts stay on the GPU; the host reads the live
count once, when it needs it (`ParticleSystem.live_count`): the frame's only wait.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import moderngl
import numpy as np

from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.drops import DROPPED
from cavesim.gpu.engine.emission import Emission
from cavesim.gpu.engine.pass_timers import PassTimers
from cavesim.gpu.engine.programs import (
    BLOCK_WORKGROUP_SIZE,
    append_program,
    block_update_program,
    compact_program,
    scan_program,
)
from cavesim.gpu.engine.uniforms import write_uniforms
from cavesim.gpu.gl import denormal_probe
from cavesim.gpu.gl.denormals import flushing_denormals

log = logging.getLogger(__name__)

BLOCK = 32  # particles per invocation of passes 1 and 3: one uint of survivor bits (streams.glsl)
# Storage-buffer bindings, as shaders/include/streams.glsl declares them
FRONT, BACK, ALIVE_MASKS, OFFSETS, EMITTER_STATES, FRAME_COUNTS = range(6)

BufferFactory = Callable[[str, int], moderngl.Buffer]


def block_count(particles: int) -> int:
    """Blocks of BLOCK particles that hold `particles`."""
    return -(-particles // BLOCK)


class ComputePasses:
    """The particle pass, compaction and emission of one frame, by compute shaders."""

    def __init__(self, ctx: moderngl.Context, scene: Scene,
                 particles: Sequence[moderngl.Buffer], emitters: Sequence[moderngl.Buffer],
                 bind_samplers: Callable[[moderngl.Program], None],
                 buffer: BufferFactory, timers: PassTimers) -> None:
        self._ctx = ctx
        self._timers = timers
        self._particles = particles
        self._emitters = emitters
        self._bind_samplers = bind_samplers
        self._buffer = buffer
        self._capacity = scene.capacity
        self._emitter_count = len(scene.emitters)
        self._max_groups = int(ctx.info["GL_MAX_COMPUTE_WORK_GROUP_COUNT"][0])
        self.program = block_update_program(ctx, scene)
        self._scan = scan_program(ctx)
        self._compact = compact_program(ctx)
        self._append = append_program(ctx, scene) if emitters else None
        self._masks = buffer("alive_masks", block_count(scene.capacity) * 4)
        self._counts = buffer("frame_counts", DROPPED + 4)
        self._offset_entries = block_count(scene.capacity) + self._emitter_count
        self._offsets = buffer("offsets", self._offset_entries * 4)
        self.denormals_agree = _denormals_agree(ctx)

    @property
    def counts_buffer(self) -> moderngl.Buffer:
        """The storage buffer holding the last frame's live and dropped counts (`drops.py`)."""
        return self._counts

    def advance(self, front: int, back: int, live: int, emission: Emission | None) -> None:
        """Survivors of the `live` front particles, then the new ones, into the back buffer.

        The new live count stays on the GPU, in `counts_buffer`.
        """
        blocks = block_count(live)
        segments = 0 if emission is None else emission.batches * self._emitter_count
        self._reserve_offsets(blocks + segments)
        self._bind(front, back)
        with flushing_denormals():  # a dispatch may run on this thread (LP_NUM_THREADS=0)
            self._dispatch(blocks, segments, live, emission)
        # The frame's writes are read next as storage (checksum, next frame), as vertex
        # attributes (rendering) and by buffer reads (snapshots): make them visible to all.
        self._ctx.memory_barrier()

    def _dispatch(self, blocks: int, segments: int, live: int,
                  emission: Emission | None) -> None:
        with self._timers.segment("particle_pass"):
            self._survivors(blocks, segments, live)
        if segments:
            with self._timers.segment("emitter_pass"):
                self._append_new(blocks, segments, emission)

    def _survivors(self, blocks: int, segments: int, live: int) -> None:
        """Step the live particles, count the survivors and the new ones, and compact the
        survivors into the back buffer."""
        if blocks:
            self._update(live)
        write_uniforms(self._scan, {"block_count": np.uint32(blocks),
                                    "segment_count": np.uint32(segments),
                                    "emitter_count": np.uint32(self._emitter_count),
                                    "capacity": np.uint32(self._capacity)})
        self._scan.run(1)
        self._ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)
        if blocks:
            write_uniforms(self._compact, {"block_count": np.uint32(blocks)})
            self._compact.run(-(-blocks // BLOCK_WORKGROUP_SIZE))

    def particle_pass(self, front: int, back: int, live: int) -> None:
        """Pass 1 alone (the benchmark times it): step the front buffer's `live` particles
        in place and write their survivor masks."""
        self._bind(front, back)
        with flushing_denormals():
            self._update(live)
        self._ctx.memory_barrier()

    def _update(self, live: int) -> None:
        write_uniforms(self.program, {"particle_count": np.uint32(live)})
        self._bind_samplers(self.program)
        self.program.run(-(-block_count(live) // BLOCK_WORKGROUP_SIZE))
        self._ctx.memory_barrier(moderngl.SHADER_STORAGE_BARRIER_BIT)

    def _bind(self, front: int, back: int) -> None:
        for buffer, binding in ((self._particles[front], FRONT), (self._particles[back], BACK),
                                (self._masks, ALIVE_MASKS), (self._offsets, OFFSETS),
                                (self._counts, FRAME_COUNTS)):
            buffer.bind_to_storage_buffer(binding)
        if self._emitters:
            self._emitters[back].bind_to_storage_buffer(EMITTER_STATES)

    def _append_new(self, blocks: int, segments: int, emission: Emission) -> None:
        write_uniforms(self._append, {"random_transform": emission.random_transform.T,
                                      "block_count": np.uint32(blocks),
                                      "emitter_count": np.uint32(self._emitter_count),
                                      "capacity": np.uint32(self._capacity)})
        self._bind_samplers(self._append)
        # one work group per segment, in dispatches within the driver's group-count limit
        for first in range(0, segments, self._max_groups):
            write_uniforms(self._append, {"first_segment": np.uint32(first)})
            self._append.run(min(self._max_groups, segments - first))

    def _reserve_offsets(self, entries: int) -> None:
        """Grow the offsets buffer to `entries` (a frame with more emission segments)."""
        if entries <= self._offset_entries:
            return
        self._offsets.release()
        self._offset_entries = max(entries, 2 * self._offset_entries)
        self._offsets = self._buffer("offsets", self._offset_entries * 4)



def _denormals_agree(ctx: moderngl.Context) -> bool:
    """Whether draws and dispatches treat denormals alike on `ctx` (probed once per context);
    logged when they do not: this path then parts from GS/TF walls."""
    extra = ctx.extra if isinstance(getattr(ctx, "extra", None), dict) else {}
    if "denormals_agree" not in extra:
        extra["denormals_agree"] = denormal_probe.probe(ctx)
        if not extra["denormals_agree"]:
            log.warning("compute engine path: %s treats denormal floats differently in "
                        "draws and compute dispatches; walls on the gs_tf path will part "
                        "from this one (a cluster on one path stays consistent)",
                        ctx.info["GL_RENDERER"])
    return extra["denormals_agree"]
