"""One case run with one integrator over every dt: on the GPU (timed) and in the float64 twin.

Both start each dt from the case's particle set and take round(T / dt) frames of the same
FrameInput, so they end at the same time, n * float32(dt). GL calls are asynchronous:
every timed step ends in `ctx.finish()`; the median step time is kept. A case whose field is
a time series has a scene per dt (its snapshots a number of steps apart), and a scene
frame per step (where the series stands).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.core.errors import CavesimError
from cavesim.core.position import extended_position
from cavesim.core.scene.model import Arithmetic, FieldSampling, Integrator, Scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.tools.numerics.cases import Case

IDENTITY = np.eye(3, dtype=np.float32)  # no emitters: the random texture is never read
WARMUP_STEPS = 2  # untimed, on a throwaway copy of the state: shader JIT, first touch


class AccuracyError(CavesimError, RuntimeError):
    """A run lost particles or left GL in an error state: its errors would be meaningless."""


@dataclass(frozen=True)
class GpuVariant:
    """How the GPU runs a case: its field sampling and its arithmetic."""

    name: str
    sampling: FieldSampling = FieldSampling.MANUAL
    arithmetic: Arithmetic = Arithmetic.NATIVE


MANUAL = GpuVariant("manual")  # the engine's default: manual trilinear, native arithmetic
HARDWARE = GpuVariant("hardware", sampling=FieldSampling.HARDWARE)
PORTABLE = GpuVariant("portable", arithmetic=Arithmetic.PORTABLE)


@dataclass(frozen=True)
class Run:
    dt: float  # s, as asked (the engine steps by float32(dt))
    steps: int
    end_time: float  # s, steps * float32(dt)
    pos: np.ndarray  # (N, 3) float64 final positions
    vel: np.ndarray  # (N, 3) float64 final velocities
    step_seconds: float = float("nan")  # median wall time of one GPU step; NaN for the twin


def steps_to(final_time: float, dt: float) -> int:
    return round(final_time / dt)


def end_time(final_time: float, dt: float) -> float:
    return steps_to(final_time, dt) * float(np.float32(dt))


def gpu_runs(ctx: moderngl.Context, case: Case, integrator: Integrator, variant: GpuVariant,
             dts: tuple[float, ...], final_time: float,
             tick: Callable[[], None] = lambda: None) -> list[Run]:
    """Final states and step times of the GPU engine, one run per dt."""
    runs = []
    for scene, group in _scenes(case, integrator, variant, dts, final_time):
        system = ParticleSystem(ctx, scene)
        try:
            system.write_particles(case.particles)
            for k in range(WARMUP_STEPS):
                system.step(FrameInput(group[0], IDENTITY), case.frame_at(scene, k, group[0]))
            ctx.finish()
            for dt in group:
                runs.append(_timed_run(ctx, system, case, dt, final_time))
                tick()
        finally:
            system.release()
    if (error := ctx.error) != "GL_NO_ERROR":
        raise AccuracyError(f"GL reported {error} running {case.name} with {integrator.value} "
                            f"({variant.name})")
    return runs


def _scenes(case: Case, integrator: Integrator, variant: GpuVariant, dts: tuple[float, ...],
            final_time: float) -> list[tuple[Scene, tuple[float, ...]]]:
    """The scenes to run and the dts of each: one for every dt, or a time series' per dt."""
    def scene(dt: float) -> Scene:
        return case.scene(integrator, variant.sampling, variant.arithmetic, dt, final_time)

    if case.snapshot_steps is None:
        return [(scene(dts[0]), dts)]
    return [(scene(dt), (dt,)) for dt in dts]


def _timed_run(ctx: moderngl.Context, system: ParticleSystem, case: Case, dt: float,
               final_time: float) -> Run:
    system.write_particles(case.particles)
    frame, steps = FrameInput(dt, IDENTITY), steps_to(final_time, dt)
    seconds = []
    for k in range(steps):
        scene_frame = case.frame_at(system.scene, k, dt)
        start = time.perf_counter()
        system.step(frame, scene_frame)
        ctx.finish()
        seconds.append(time.perf_counter() - start)
    _check_count(system.live_count, case, f"GPU, dt={dt:.6g}")
    state = system.read_particles()
    return Run(dt, steps, end_time(final_time, dt), extended_position(state),
               state["vel"].astype(np.float64), statistics.median(seconds))


def twin_runs(case: Case, integrator: Integrator, dts: tuple[float, ...],
              final_time: float) -> list[Run]:
    """Final states of the float64 twin, one run per dt."""
    runs = []
    for scene, group in _scenes(case, integrator, MANUAL, dts, final_time):
        twin = TwinSystem(scene, np.float64)
        for dt in group:
            runs.append(_twin_run(twin, case, integrator, dt, final_time))
    return runs


def _twin_run(twin: TwinSystem, case: Case, integrator: Integrator, dt: float,
              final_time: float) -> Run:
    twin.write_particles(case.particles)
    frame, steps = FrameInput(dt, IDENTITY), steps_to(final_time, dt)
    for k in range(steps):
        twin.step(frame, case.frame_at(twin.scene, k, dt))
    _check_count(twin.live_count, case, f"float64 twin, {integrator.value}, dt={dt:.6g}")
    return Run(dt, steps, end_time(final_time, dt), twin.particles.position(),
               twin.particles.vel.copy())


def _check_count(live: int, case: Case, what: str) -> None:
    if live != len(case.particles):
        raise AccuracyError(f"{case.name} ({what}): {len(case.particles) - live} of "
                            f"{len(case.particles)} particles were dropped as runaway; the "
                            f"errors need every particle")
