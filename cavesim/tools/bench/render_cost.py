"""`cavesim bench --render`: what drawing one wall for one eye costs, by wall resolution and
particle count, and the renderer's target.

A measurement is a wall's first draw of a state: the light map's splat and
`WallRenderer.draw`, followed by `ctx.finish()` (the GPU's work done; a node of several walls
or eyes splats the map once per state, and draws each wall and eye after it), from
the scripted head's start (the CAVE's centre at eye height) looking at a front wall of the
resolution asked: the default CAVE's 3 m front wall (the caller's), its height set by the
resolution so that pixels stay square (480 x 480: flex4's front wall itself). The particles are the
scene's state at a built-up frame of its master's inputs, or a full pool of N particles of
the scene (`workload.preload`: spread over its field box).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.core.cave.geometry import Wall
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import HelicopterPose
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer
from cavesim.tools.bench.figures import applies_to
from cavesim.tools.bench.measure import ground_grid
from cavesim.tools.bench.workload import preload
from cavesim.tools.reports.scene_pictures import scene_inputs

RESOLUTIONS = ((480, 480), (1920, 1200))  # flex4's walls, and a 16:10 projector's
RENDER_SCENE = "config/scenes/brownout.toml"
BUILT_UP_FRAME = 720  # the brownout demo's cloud as its docs picture shows it
WARMUP_DRAWS = 3  # absorb shader compilation and first-touch costs
RENDER_DRAWS = 20  # timed draws per measurement
HEAD = ScriptedHead().at(0.0).position  # the CAVE's centre at eye height


@dataclass(frozen=True)
class RenderTarget:
    bound_ms: float  # p50 of one wall's draw for one eye, at most
    resolution: tuple[int, int]
    particles: int  # a full pool of this many
    renderer: str  # where it applies: "llvmpipe" or "GPU"
    meaning: str

    def evaluate(self, costs: list[DrawCost], software: bool) -> dict[str, object]:
        """Judged on the pool of `particles` at `resolution` where measured, and only on
        the renderer it is meant for (`met` None elsewhere, `applies` False)."""
        judged = [c for c in costs if c.resolution == self.resolution and c.pool
                  and c.particles == self.particles]
        measured = judged[0].p50_ms if judged else None
        applies = applies_to(self.renderer, software)
        return {"meaning": self.meaning, "comparison": "<=", "target_ms": self.bound_ms,
                "resolution": list(self.resolution), "particles": self.particles,
                "renderer": self.renderer, "applies": applies, "measured_ms": measured,
                "met": measured <= self.bound_ms if applies and judged else None}


RENDER_TARGET = RenderTarget(4.0, (1920, 1200), 1_000_000, "GPU",
                             "one wall for one eye of a new state: the light map's splat and "
                             "WallRenderer.draw, waited for")


@dataclass(frozen=True)
class DrawCost:
    workload: str  # what was drawn, in words
    particles: int  # live particles drawn
    pool: bool  # a full pool of `particles`, not a scene's built-up state
    resolution: tuple[int, int]
    wall_m: tuple[float, float]  # the wall's width and height
    times_s: tuple[float, ...]  # each timed draw

    @property
    def p50_ms(self) -> float:
        return float(np.median(self.times_s)) * 1e3

    @property
    def p90_ms(self) -> float:
        return float(np.percentile(self.times_s, 90)) * 1e3

    def to_json(self) -> dict[str, object]:
        return {"workload": self.workload, "particles": self.particles, "pool": self.pool,
                "resolution": list(self.resolution), "wall_m": list(self.wall_m),
                "draws": len(self.times_s), "p50_ms": round(self.p50_ms, 3),
                "p90_ms": round(self.p90_ms, 3),
                "draws_per_s": round(1e3 / self.p50_ms, 2),
                "particles_per_s": round(self.particles / self.p50_ms * 1e3)}


def front_wall(front: Wall, resolution: tuple[int, int]) -> Wall:
    """`front` as wide and centred as high, its height making its pixels square at
    `resolution`."""
    centre_z = (front.lower_left[2] + front.upper_left[2]) / 2
    half = front.width * resolution[1] / resolution[0] / 2
    low, high = front.lower_left.copy(), front.lower_right.copy()
    low[2] = high[2] = centre_z - half
    upper = low.copy()
    upper[2] = centre_z + half
    return Wall("front", low, high, upper, resolution)


Workload = tuple[str, ParticleSystem, HelicopterPose | None, bool]


def workloads(ctx: moderngl.Context, scene: Scene, sizes: list[int] | None,
              frame: int) -> Iterator[Workload]:
    """The scene at `frame` of its master's inputs, or (with `sizes`) a full pool of each
    size; each system is released once the next is asked for. The helicopter is the one
    of `frame` in both."""
    inputs = list(scene_inputs(scene, frame))
    helicopter = inputs[-1][1].helicopter
    if not sizes:
        system = ParticleSystem(ctx, scene)
        try:
            for frame_input, scene_frame in inputs:
                system.step(frame_input, scene_frame)
            yield f"{scene.name} at frame {frame}", system, helicopter, False
        finally:
            system.release()
        return
    for count in sizes:
        pooled = dataclasses.replace(scene, capacity=count)
        system = ParticleSystem(ctx, pooled)
        try:
            system.write_particles(preload(pooled, count, ground_grid(pooled)))
            yield f"pool of {count:,}", system, helicopter, True
        finally:
            system.release()


def time_draws(ctx: moderngl.Context, renderer: WallRenderer, helicopter, draws: int
               ) -> tuple[float, ...]:
    """Seconds of each of `draws` draws after WARMUP_DRAWS, each waited for."""
    times = []
    for k in range(WARMUP_DRAWS + draws):
        start = time.perf_counter()
        renderer.light_map.splat()
        renderer.draw(HEAD, helicopter)
        ctx.finish()
        if k >= WARMUP_DRAWS:
            times.append(time.perf_counter() - start)
    return tuple(times)


def measure_render(ctx: moderngl.Context, scene: Scene, front: Wall,
                   resolutions: list[tuple[int, int]], sizes: list[int] | None, frame: int,
                   draws: int, measured: Callable[[DrawCost], None]) -> None:
    """Every workload at every resolution (`front` reshaped by `front_wall`), each handed
    to `measured` once taken."""
    for name, system, helicopter, pool in workloads(ctx, scene, sizes, frame):
        live = system.live_count
        for resolution in resolutions:
            wall = front_wall(front, resolution)
            renderer = WallRenderer(ctx, system, wall, RenderSettings())
            try:
                times = time_draws(ctx, renderer, helicopter, draws)
            finally:
                renderer.release()
            measured(DrawCost(name, live, pool, tuple(resolution), (wall.width, wall.height),
                              times))
