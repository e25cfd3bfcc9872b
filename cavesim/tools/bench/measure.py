"""Timing of the four benchmarked paths at one size, all on the caller's GL context.

GL calls are asynchronous, so every timed GL action ends in `ctx.finish()` (the checksum
reads its sums back, which waits by itself). Each path gets warm-up frames, which absorb
shader compilation and first-touch costs, then the median of the timed frames is kept.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Callable

import moderngl
import numpy as np

from cavesim.core.errors import CavesimError
from cavesim.core.scene.model import Scene
from cavesim.core.twin import TwinSystem
from cavesim.gpu.engine.particle_system import FIELD_UNIT, GROUND_UNIT, ParticleSystem
from cavesim.gpu.engine.programs import in_place_update_program
from cavesim.gpu.engine.uniforms import physics_uniforms, write_uniforms
from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.workload import FRAME_DT, frame_inputs, preload

WARMUP_FRAMES = 2
NUMPY_WARMUP_FRAMES = 1
COMPUTE_LOCAL_SIZE = 64  # layout(local_size_x = 64) in shaders/particles/update_in_place.glsl

Tick = Callable[[str], None]  # called after every warm-up or timed frame, with the path name


class BenchError(CavesimError, RuntimeError):
    """The benchmark left GL in an error state: its figures would be meaningless."""


def numpy_frames(frames: int) -> int:
    """Timed frames of the numpy twin: fewer, it is slow at large sizes."""
    return max(2, frames // 3)


def ticks_per_size(frames: int) -> int:
    """How often `measure_size` calls its tick, for a progress bar."""
    return 3 * (WARMUP_FRAMES + frames) + NUMPY_WARMUP_FRAMES + numpy_frames(frames)


def median_seconds(action: Callable[[], object], warmup: int, frames: int,
                   tick: Callable[[], None]) -> float:
    """Median wall time of `frames` calls of `action` after `warmup` untimed ones."""
    for _ in range(warmup):
        action()
        tick()
    times = []
    for _ in range(frames):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
        tick()
    return statistics.median(times)


def measure_size(ctx: moderngl.Context, scene: Scene, count: int, frames: int,
                 tick: Tick) -> SizeFigures:
    """Time every path on a full pool of `count` particles of `scene`."""
    scene = dataclasses.replace(scene, capacity=count)
    system = ParticleSystem(ctx, scene)
    records = preload(scene, count, system.ground_grid)
    system.write_particles(records)
    inputs = iter(frame_inputs(scene, WARMUP_FRAMES + frames))

    def gs_tf_step() -> None:
        system.step(next(inputs))
        ctx.finish()

    try:
        gs_tf = median_seconds(gs_tf_step, WARMUP_FRAMES, frames, lambda: tick("GS/TF step"))
        checksum = median_seconds(system.checksum, WARMUP_FRAMES, frames,
                                  lambda: tick("checksum"))
        compute = _compute_bound_seconds(ctx, scene, system, records, frames, tick)
        live_after = system.live_count
    finally:
        system.release()
    numpy_s = _numpy_twin_seconds(scene, records, frames, tick)
    if (error := ctx.error) != "GL_NO_ERROR":
        raise BenchError(f"GL reported {error} while benchmarking {count} particles")
    return SizeFigures(count, gs_tf, compute, numpy_s, checksum, frames, numpy_frames(frames),
                       live_after)


def _compute_bound_seconds(ctx: moderngl.Context, scene: Scene, system: ParticleSystem,
                           records: np.ndarray, frames: int, tick: Tick) -> float:
    """The particle pass's arithmetic in place in a storage buffer: no emission, no kill."""
    program = in_place_update_program(ctx, scene)
    write_uniforms(program, physics_uniforms(scene, system.field_grid, system.ground_grid))
    write_uniforms(program, {"dt": np.float32(FRAME_DT),
                             "particle_count": np.uint32(len(records))})
    for name, unit in (("flow_field", FIELD_UNIT), ("ground_height", GROUND_UNIT)):
        if name in system.resources:
            system.resources[name].use(unit)
            if name in program:
                program[name].value = unit
    words = ctx.buffer(records.tobytes())  # its own copy: the GS/TF buffers stay untouched
    groups = -(-len(records) // COMPUTE_LOCAL_SIZE)

    def update_in_place() -> None:
        words.bind_to_storage_buffer(0)  # the checksum binds binding 0 too
        program.run(groups)
        ctx.finish()

    try:
        return median_seconds(update_in_place, WARMUP_FRAMES, frames,
                              lambda: tick("compute bound"))
    finally:
        words.release()
        program.release()


def _numpy_twin_seconds(scene: Scene, records: np.ndarray, frames: int, tick: Tick) -> float:
    twin = TwinSystem(scene, dtype=np.float32)
    twin.write_particles(records)
    inputs = iter(frame_inputs(scene, NUMPY_WARMUP_FRAMES + numpy_frames(frames)))
    return median_seconds(lambda: twin.step(next(inputs)), NUMPY_WARMUP_FRAMES,
                          numpy_frames(frames), lambda: tick("numpy twin"))
