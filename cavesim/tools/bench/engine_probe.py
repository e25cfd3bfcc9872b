"""`engine = "auto"`: which engine path is faster on this context, by a short timed probe.

Each path steps whole frames (step, then the checksum that waits for it) of the scene on a
full pool of PROBE_PARTICLES at most (the scene's capacity, else fewer: the probe must take
a moment, not the start-up), the benchmark's workload. The faster median wins; within
TIE_MARGIN the scene's reference, GS/TF, does. A node probes once, before it joins; the
master then has every node of the run step with one path (nodes/master/engine_choice.py).
"""

from __future__ import annotations

import dataclasses

import moderngl

from cavesim.core.scene.model import ENGINE_PATHS, Engine, Scene
from cavesim.gpu.engine.particle_system import ParticleSystem
from cavesim.tools.bench.measure import BenchPlan, ground_grid, time_whole_frames
from cavesim.tools.bench.workload import preload

PROBE_PARTICLES = 1_000_000  # at most: a GPU's frame of them takes about a millisecond
PROBE = BenchPlan(frames=8, path_budget_s=0.5)  # median of up to 8 frames, at most ~0.5 s
TIE_MARGIN = 0.05  # compute must be this much faster to be chosen over GS/TF


@dataclasses.dataclass(frozen=True)
class EngineProbe:
    seconds: dict[Engine, float]  # median frame of each path
    particles: int

    @property
    def faster(self) -> Engine:
        gs_tf, compute = (self.seconds[path] for path in ENGINE_PATHS)
        return Engine.COMPUTE if compute < gs_tf * (1 - TIE_MARGIN) else Engine.GS_TF

    def line(self) -> str:
        """One line for the node's log."""
        times = ", ".join(f"{path} {seconds * 1e3:.2f} ms" for path, seconds in
                          self.seconds.items())
        return f"engine auto: {times} a frame of {self.particles:,} particles: {self.faster}"


def probe_engines(ctx: moderngl.Context, scene: Scene) -> EngineProbe:
    count = min(scene.capacity, PROBE_PARTICLES)
    probed = dataclasses.replace(scene, capacity=count)
    records = preload(probed, count, ground_grid(probed))
    seconds = {}
    for path in ENGINE_PATHS:
        system = ParticleSystem(ctx, dataclasses.replace(probed, engine=path))
        try:
            seconds[path] = time_whole_frames(system, probed, records, PROBE).seconds
        finally:
            system.release()
    return EngineProbe(seconds, count)
