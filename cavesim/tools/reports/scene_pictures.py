"""Any scene's walls in pictures, and the two faults a shipped scene must not show.

One GL context plays a scene with the master's inputs (its driver's frames, a random
transform per frame from the clock seed, the scripted head) and draws every wall of a CAVE
at chosen frames, each also without its dust, as `cavesim run` would (the walls of a run
hold the same bits). The faults: a whiteout, where the dust hides the world, measured as
the share of a wall that dust changed into its own lit colour; and a blank wall, one with
next to no variation in it.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.core.cave.geometry import Cave
from cavesim.core.drivers import driver_for
from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.medium import lit_dust_colours
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer

FRAME_DT = 1 / 60
CLOCK_SEED = 7  # the transforms' generator, as a master's clock seed
DUST_LEVELS = 12  # a pixel is clouded where dust changed it by more than this (of 255)
SETTINGS = RenderSettings()  # what the walls are drawn with
NEAR_DUST = 24  # levels (RGB distance) from the dust's lit colour: what a viewer reads as dust


@dataclass(frozen=True)
class Walls:
    """One frame's wall pictures ((height, width, 3) uint8 by wall name), the same views
    without dust, the particles and the scene's frame."""

    pictures: dict[str, np.ndarray]
    clear: dict[str, np.ndarray]
    particles: np.ndarray
    scene_frame: SceneFrame


def scene_inputs(scene: Scene, frames: int) -> Iterator[tuple[FrameInput, SceneFrame]]:
    """The inputs a master sends for frames 1..frames: dt, transform, the driver's scene."""
    driver = driver_for(scene)
    rng = np.random.Generator(np.random.PCG64(CLOCK_SEED))
    for k in range(1, frames + 1):
        scene_frame = driver.decode(driver.encode(driver.advance(k * FRAME_DT, FRAME_DT,
                                                                 None).frame))
        yield FrameInput(FRAME_DT, draw_transform(rng, scene.random_texture_size)), scene_frame


def draw_walls(ctx: moderngl.Context, scene: Scene, cave: Cave, at: set[int]
               ) -> dict[int, Walls]:
    """Frame k in `at` -> every wall of `cave` drawn from the scripted head."""
    system, empty = ParticleSystem(ctx, scene), ParticleSystem(ctx, scene)
    renderers = {w.name: WallRenderer(ctx, system, w, SETTINGS) for w in cave.walls}
    clear = {w.name: WallRenderer(ctx, empty, w, SETTINGS) for w in cave.walls}
    head = ScriptedHead()
    out = {}
    try:
        for k, (frame, scene_frame) in enumerate(scene_inputs(scene, max(at)), start=1):
            system.step(frame, scene_frame)
            if k in at:
                eye = head.at(k * FRAME_DT).position
                out[k] = Walls({n: r.render(eye, scene_frame.helicopter)
                                for n, r in renderers.items()},
                               {n: r.render(eye, scene_frame.helicopter)
                                for n, r in clear.items()},
                               system.read_particles(), scene_frame)
    finally:
        for r in (*renderers.values(), *clear.values()):
            r.release()
        system.release()
        empty.release()
    return out


def dust_colour_distance(picture: np.ndarray) -> np.ndarray:
    """Per pixel: RGB distance (levels) to the nearest colour opaque lit dust takes, from
    dust in the shade (skylit: `dust_ambient` of the sunlight) to dust in full sun."""
    rgb = np.asarray(picture, dtype=float)
    return np.min([np.linalg.norm(rgb - colour, axis=-1)
                   for colour in lit_dust_colours(SETTINGS)], axis=0)


def whiteout_share(picture: np.ndarray, clear: np.ndarray) -> float:
    """The share of the picture that dust changed (by more than DUST_LEVELS) into a
    colour within NEAR_DUST of its own: the world hidden behind it."""
    changed = np.abs(picture.astype(np.int16) - clear.astype(np.int16)).max(axis=2)
    hidden = (changed > DUST_LEVELS) & (dust_colour_distance(picture) < NEAR_DUST)
    return float(hidden.mean())


def variation(picture: np.ndarray) -> float:
    """The standard deviation of the picture's grey levels: 0 for one colour."""
    return float(np.asarray(picture, dtype=float).mean(axis=2).std())
