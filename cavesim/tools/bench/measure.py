"""Timing of every benchmarked path at one size, all on the caller's GL context.

GL calls are asynchronous, so every timed GL action ends waiting for the GPU (a checksum
reads its sums back; the rest end in `ctx.finish()`). Each path gets warm-up frames, which
absorb shader compilation and first-touch costs, then the median of the timed frames is
kept. Both engine paths step the same particles with the same frames.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Callable

import moderngl
import numpy as np

from cavesim.core.errors import CavesimError
from cavesim.core.heightfield import HeightGrid, load_heightfield
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.scene.model import Arithmetic, CollisionKind, Engine, Scene
from cavesim.core.twin import TwinSystem
from cavesim.gpu.engine.particle_system import ParticleSystem
from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.workload import FRAME_DT, frame_inputs, preload

WARMUP_FRAMES = 2
NUMPY_WARMUP_FRAMES = 1
GL_PATHS = 8  # timed per size on the GL context: 2 native and 2 portable frames, 2 updates,
# checksum, copy

Tick = Callable[[str], None]  # called after every warm-up or timed frame, with the path name


class BenchError(CavesimError, RuntimeError):
    """The benchmark left GL in an error state: its figures would be meaningless."""


def numpy_frames(frames: int) -> int:
    """Timed frames of the numpy twin: fewer, it is slow at large sizes."""
    return max(2, frames // 3)


def ticks_per_size(frames: int) -> int:
    """How often `measure_size` calls its tick, for a progress bar."""
    return GL_PATHS * (WARMUP_FRAMES + frames) + NUMPY_WARMUP_FRAMES + numpy_frames(frames)


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


@dataclasses.dataclass(frozen=True)
class _PathTimes:
    frame: float
    update: float
    checksum: float
    live_after: int


def measure_size(ctx: moderngl.Context, scene: Scene, count: int, frames: int,
                 tick: Tick) -> SizeFigures:
    """Time every path on a full pool of `count` particles of `scene`."""
    scene = dataclasses.replace(scene, capacity=count)
    records = preload(scene, count, _ground_grid(scene))
    gs_tf = _engine_seconds(ctx, scene, Engine.GS_TF, records, frames, tick)
    compute = _engine_seconds(ctx, scene, Engine.COMPUTE, records, frames, tick)
    portable = [_portable_frame_seconds(ctx, scene, engine, records, frames, tick)
                for engine in (Engine.GS_TF, Engine.COMPUTE)]
    copy = _copy_seconds(ctx, records, frames, tick)
    numpy_s = _numpy_twin_seconds(scene, records, frames, tick)
    if (error := ctx.error) != "GL_NO_ERROR":
        raise BenchError(f"GL reported {error} while benchmarking {count} particles")
    return SizeFigures(count, gs_tf.frame, compute.frame, *portable, gs_tf.update,
                       compute.update, gs_tf.checksum, copy, numpy_s, frames,
                       numpy_frames(frames), min(gs_tf.live_after, compute.live_after))


def _ground_grid(scene: Scene) -> HeightGrid | None:
    """The scene's height field, if it has one: where the preloaded pool starts."""
    collision = scene.collision
    if collision is None or collision.kind is not CollisionKind.HEIGHTFIELD:
        return None
    return load_heightfield(collision.file)


def _engine_seconds(ctx: moderngl.Context, scene: Scene, engine: Engine,
                    records: np.ndarray, frames: int, tick: Tick) -> _PathTimes:
    """One engine path: whole frames (step + checksum), then its particle pass alone."""
    system = ParticleSystem(ctx, dataclasses.replace(scene, engine=engine))
    try:
        frame_s = _frame_seconds(system, scene, records, frames, lambda: tick(f"{engine} frame"))
        live_after = system.live_count
        checksum_s = median_seconds(system.checksum, WARMUP_FRAMES, frames,
                                    lambda: tick("checksum")) if engine is Engine.GS_TF else 0.0
        update_s = median_seconds(lambda: system.bench_particle_pass(np.float32(FRAME_DT)),
                                  WARMUP_FRAMES, frames, lambda: tick(f"{engine} update"))
    finally:
        system.release()
    return _PathTimes(frame_s, update_s, checksum_s, live_after)


def _portable_frame_seconds(ctx: moderngl.Context, scene: Scene, engine: Engine,
                            records: np.ndarray, frames: int, tick: Tick) -> float:
    """Whole frames of one engine path with the scene's arithmetic portable."""
    portable = dataclasses.replace(scene, engine=engine, arithmetic=Arithmetic.PORTABLE)
    system = ParticleSystem(ctx, portable)
    try:
        return _frame_seconds(system, scene, records, frames,
                              lambda: tick(f"{engine} portable frame"))
    finally:
        system.release()


def _frame_seconds(system: ParticleSystem, scene: Scene, records: np.ndarray, frames: int,
                   tick: Callable[[], None]) -> float:
    """Median whole frame (step, then the checksum that waits for it) from `records`."""
    system.write_particles(records)
    inputs = iter(frame_inputs(scene, WARMUP_FRAMES + frames))

    def frame() -> None:
        system.step(*next(inputs))
        system.checksum()  # reads back: the frame is done

    return median_seconds(frame, WARMUP_FRAMES, frames, tick)


def _copy_seconds(ctx: moderngl.Context, records: np.ndarray, frames: int,
                  tick: Tick) -> float:
    """The memory-bandwidth bound: one GPU-side copy of the particle state (read + write)."""
    size = max(len(records) * PARTICLE_BYTES, 4)
    source, target = ctx.buffer(records.tobytes() or b"\0" * 4), ctx.buffer(reserve=size)

    def copy() -> None:
        ctx.copy_buffer(target, source, size)
        ctx.finish()

    try:
        return median_seconds(copy, WARMUP_FRAMES, frames, lambda: tick("copy bound"))
    finally:
        source.release()
        target.release()


def _numpy_twin_seconds(scene: Scene, records: np.ndarray, frames: int, tick: Tick) -> float:
    twin = TwinSystem(scene, dtype=np.float32)
    twin.write_particles(records)
    inputs = iter(frame_inputs(scene, NUMPY_WARMUP_FRAMES + numpy_frames(frames)))
    return median_seconds(lambda: twin.step(*next(inputs)), NUMPY_WARMUP_FRAMES,
                          numpy_frames(frames), lambda: tick("numpy twin"))
