"""Timing of every benchmarked path at one size, all on the caller's GL context.

GL calls are asynchronous, so every timed GL action ends waiting for the GPU (a checksum
reads its sums back; the rest end in `ctx.finish()`). Each path gets warm-up frames, which
absorb shader compilation and first-touch costs, then the median of the timed frames is
kept: `BenchPlan.frames` of them, fewer (at least MIN_TIMED_FRAMES) once a path's timed
frames have taken PATH_BUDGET_S, so that the largest sizes end in bounded time. Both
engine paths step the same particles; the numpy twin is timed only up to a size cap.
"""

from __future__ import annotations

import dataclasses
import statistics
import time
from collections.abc import Callable

import moderngl
import numpy as np

from cavesim.core.errors import CavesimError
from cavesim.core.features.collision import CollisionKind
from cavesim.core.fields.heights import HeightGrid, load_heightfield
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.scene.model import ENGINE_PATHS, Arithmetic, Engine, Scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine.particle_system import ParticleSystem
from cavesim.tools.bench.figures import SizeFigures
from cavesim.tools.bench.workload import FRAME_DT, frame_inputs, preload

WARMUP_FRAMES = 2
NUMPY_WARMUP_FRAMES = 1
PATH_BUDGET_S = 2.0  # timed seconds per path and size after which no frame is started
MIN_TIMED_FRAMES = 3  # a median of fewer would be one frame's noise
NUMPY_UP_TO = 1_000_000  # particles; beyond, the twin's step takes seconds (0.7 s at 1M, 2 cores)


@dataclasses.dataclass(frozen=True)
class BenchPlan:
    frames: int  # timed frames per path at most
    numpy_up_to: int = NUMPY_UP_TO  # the largest size at which the numpy twin is timed
    path_budget_s: float = PATH_BUDGET_S


@dataclasses.dataclass(frozen=True)
class Timing:
    seconds: float  # median of the timed frames
    frames: int  # how many were timed


Measured = Callable[[str, Timing | None], None]  # after each path of PATHS; None: not timed


class BenchError(CavesimError, RuntimeError):
    """The benchmark left GL in an error state: its figures would be meaningless."""


def numpy_frames(frames: int) -> int:
    """Timed frames of the numpy twin at most: fewer, it is slow at large sizes."""
    return max(2, frames // 3)


def time_frames(action: Callable[[], object], warmup: int, frames: int,
                budget_s: float) -> Timing:
    """Median wall time of up to `frames` calls of `action` after `warmup` untimed ones; no
    call is started once the timed ones took `budget_s`, past the first MIN_TIMED_FRAMES."""
    for _ in range(warmup):
        action()
    least = min(frames, MIN_TIMED_FRAMES)
    times: list[float] = []
    while len(times) < frames and (len(times) < least or sum(times) < budget_s):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return Timing(statistics.median(times), len(times))


def measure_size(ctx: moderngl.Context, scene: Scene, count: int, plan: BenchPlan,
                 measured: Measured) -> SizeFigures:
    """Time every path on a full pool of `count` particles of `scene`, handing each path's
    timing to `measured` as soon as it is taken."""
    scene = dataclasses.replace(scene, capacity=count)
    records = preload(scene, count, ground_grid(scene))
    timings: dict[str, Timing | None] = {}

    def keep(path: str, timing: Timing | None) -> None:
        timings[path] = timing
        measured(path, timing)

    live_after = min(_time_engine(ctx, scene, engine, records, plan, keep)
                     for engine in ENGINE_PATHS)
    for engine in ENGINE_PATHS:
        keep(f"{engine}_portable_frame", _time_portable_frame(ctx, scene, engine, records, plan))
    keep("copy", _time_copy(ctx, records, plan))
    numpy_timed = count <= plan.numpy_up_to
    keep("numpy", _time_numpy_twin(scene, records, plan) if numpy_timed else None)
    if (error := ctx.error) != "GL_NO_ERROR":
        raise BenchError(f"GL reported {error} while benchmarking {count} particles")
    seconds = {f"{path}_s": timing.seconds if timing else None for path, timing in timings.items()}
    frames = {path: timing.frames if timing else 0 for path, timing in timings.items()}
    return SizeFigures(count, **seconds, frames=frames, live_after=live_after)


def ground_grid(scene: Scene) -> HeightGrid | None:
    """The scene's height field, if it has one: where the preloaded pool starts."""
    collision = scene.collision
    if collision is None or collision.kind is not CollisionKind.HEIGHTFIELD:
        return None
    return load_heightfield(collision.file, scene.origin)


def _time_engine(ctx: moderngl.Context, scene: Scene, engine: Engine, records: np.ndarray,
                 plan: BenchPlan, keep: Measured) -> int:
    """One engine path: whole frames, the checksum alone (GS/TF: it is the same on both),
    then its particle pass alone; returns the live count after the frames."""
    system = ParticleSystem(ctx, dataclasses.replace(scene, engine=engine))
    try:
        keep(f"{engine}_frame", time_whole_frames(system, scene, records, plan))
        live_after = system.live_count
        if engine is Engine.GS_TF:
            keep("checksum", time_frames(system.checksum, WARMUP_FRAMES, plan.frames,
                                         plan.path_budget_s))
        keep(f"{engine}_update",
             time_frames(lambda: system.bench_particle_pass(np.float32(FRAME_DT)),
                         WARMUP_FRAMES, plan.frames, plan.path_budget_s))
    finally:
        system.release()
    return live_after


def _time_portable_frame(ctx: moderngl.Context, scene: Scene, engine: Engine,
                         records: np.ndarray, plan: BenchPlan) -> Timing:
    """Whole frames of one engine path with the scene's arithmetic portable."""
    portable = dataclasses.replace(scene, engine=engine, arithmetic=Arithmetic.PORTABLE)
    system = ParticleSystem(ctx, portable)
    try:
        return time_whole_frames(system, scene, records, plan)
    finally:
        system.release()


def time_whole_frames(system: ParticleSystem, scene: Scene, records: np.ndarray,
                       plan: BenchPlan) -> Timing:
    """Whole frames (step, then the checksum that waits for it) from `records`."""
    system.write_particles(records)
    inputs = iter(frame_inputs(scene, WARMUP_FRAMES + plan.frames))

    def frame() -> None:
        system.step(*next(inputs))
        system.checksum()  # reads back: the frame is done

    return time_frames(frame, WARMUP_FRAMES, plan.frames, plan.path_budget_s)


def _time_copy(ctx: moderngl.Context, records: np.ndarray, plan: BenchPlan) -> Timing:
    """The memory-bandwidth bound: one GPU-side copy of the particle state (read + write)."""
    size = max(len(records) * PARTICLE_BYTES, 4)
    source = ctx.buffer(records if len(records) else b"\0" * 4)  # uploads without a copy
    target = ctx.buffer(reserve=size)

    def copy() -> None:
        ctx.copy_buffer(target, source, size)
        ctx.finish()

    try:
        return time_frames(copy, WARMUP_FRAMES, plan.frames, plan.path_budget_s)
    finally:
        source.release()
        target.release()


def _time_numpy_twin(scene: Scene, records: np.ndarray, plan: BenchPlan) -> Timing:
    twin = TwinSystem(scene, dtype=np.float32)
    twin.write_particles(records)
    frames = numpy_frames(plan.frames)
    inputs = iter(frame_inputs(scene, NUMPY_WARMUP_FRAMES + frames))
    return time_frames(lambda: twin.step(*next(inputs)), NUMPY_WARMUP_FRAMES, frames,
                       plan.path_budget_s)
