"""One case run with one integrator over every dt: on the GPU (timed) and in the float64 twin.

Both start each dt from the case's particle set and take round(T / dt) frames of the same
FrameInput, so they end at the same time, n * float32(dt). GL calls are asynchronous:
every timed step ends in `ctx.finish()`; the median step time is kept.
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
from cavesim.core.scene.model import Arithmetic, FieldSampling, Integrator
from cavesim.core.twin import TwinSystem
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
    system = ParticleSystem(ctx, case.scene(integrator, variant.sampling, variant.arithmetic))
    try:
        system.write_particles(case.particles)
        for _ in range(WARMUP_STEPS):
            system.step(FrameInput(dts[0], IDENTITY), case.frame)
        ctx.finish()
        runs = []
        for dt in dts:
            runs.append(_timed_run(ctx, system, case, dt, final_time))
            tick()
    finally:
        system.release()
    if (error := ctx.error) != "GL_NO_ERROR":
        raise AccuracyError(f"GL reported {error} running {case.name} with {integrator.value} "
                            f"({variant.name})")
    return runs


def _timed_run(ctx: moderngl.Context, system: ParticleSystem, case: Case, dt: float,
               final_time: float) -> Run:
    system.write_particles(case.particles)
    frame, steps = FrameInput(dt, IDENTITY), steps_to(final_time, dt)
    seconds = []
    for _ in range(steps):
        start = time.perf_counter()
        system.step(frame, case.frame)
        ctx.finish()
        seconds.append(time.perf_counter() - start)
    _check_count(system.live_count, case, f"GPU, dt={dt:.6g}")
    state = system.read_particles()
    return Run(dt, steps, end_time(final_time, dt), extended_position(state),
               state["vel"].astype(np.float64), statistics.median(seconds))


def twin_runs(case: Case, integrator: Integrator, dts: tuple[float, ...],
              final_time: float) -> list[Run]:
    """Final states of the float64 twin, one run per dt."""
    twin = TwinSystem(case.scene(integrator), np.float64)
    runs = []
    for dt in dts:
        twin.write_particles(case.particles)
        frame, steps = FrameInput(dt, IDENTITY), steps_to(final_time, dt)
        for _ in range(steps):
            twin.step(frame, case.frame)
        _check_count(twin.live_count, case, f"float64 twin, {integrator.value}, dt={dt:.6g}")
        runs.append(Run(dt, steps, end_time(final_time, dt), twin.particles.position(),
                        twin.particles.vel.copy()))
    return runs


def _check_count(live: int, case: Case, what: str) -> None:
    if live != len(case.particles):
        raise AccuracyError(f"{case.name} ({what}): {len(case.particles) - live} of "
                            f"{len(case.particles)} particles were dropped as runaway; the "
                            f"errors need every particle")
