"""The brownout cloud in pictures and numbers (README: the brownout demo's before/after).

One GL context plays a helicopter scene with the master's inputs (its driver's frames, a
random transform per frame from the clock seed) and draws every wall of a CAVE at chosen
frames, unfolded into one composite, as `cavesim run` would (the walls of a run hold
the same bits). The measures: the share of the dust-covered picture that is one
connected cloud, and the coefficient of variation of the dust's density binned by
azimuth around the rotor (separate puffs make it large, one ring of cloud small).
"""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import numpy as np
from PIL import Image

from cavesim.core.cave.geometry import Cave
from cavesim.core.drivers import HelicopterDriver
from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import SceneFrame
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.composite import compose
from cavesim.gpu.render.wall_renderer import WallRenderer
from cavesim.nodes.script import ScriptedHead

FRAME_DT = 1 / 60
CLOCK_SEED = 7  # the transforms' generator, as a master's clock seed
DUST_LEVELS = 12  # a pixel is cloud where dust changed it by more than this (of 255)
AZIMUTH_BINS = 24


def demo_inputs(scene: Scene, frames: int) -> Iterator[tuple[FrameInput, SceneFrame]]:
    """The inputs a master sends for frames 1..frames: dt, transform, the driver's scene."""
    driver = HelicopterDriver(scene)
    rng = np.random.Generator(np.random.PCG64(CLOCK_SEED))
    for k in range(1, frames + 1):
        scene_frame = driver.decode(driver.encode(driver.advance(k * FRAME_DT, FRAME_DT,
                                                                 None).frame))
        yield FrameInput(FRAME_DT, draw_transform(rng, scene.random_texture_size)), scene_frame


def composite(renderers: dict[str, WallRenderer], cave: Cave, eye, scene_frame: SceneFrame
              ) -> Image.Image:
    return compose(cave, {name: r.render(eye, scene_frame.helicopter)
                          for name, r in renderers.items()})


def play(ctx: moderngl.Context, scene: Scene, cave: Cave, at: set[int]
         ) -> dict[int, tuple[Image.Image, Image.Image, np.ndarray, np.ndarray]]:
    """Frame k -> (composite, the same view without dust, the particles, the rotor hub)."""
    system, empty = ParticleSystem(ctx, scene), ParticleSystem(ctx, scene)
    renderers = {w.name: WallRenderer(ctx, system, w) for w in cave.walls}
    clear = {w.name: WallRenderer(ctx, empty, w) for w in cave.walls}
    head = ScriptedHead()
    out = {}
    try:
        for k, (frame, scene_frame) in enumerate(demo_inputs(scene, max(at)), start=1):
            system.step(frame, scene_frame)
            if k in at:
                eye = head.at(k * FRAME_DT).position
                out[k] = (composite(renderers, cave, eye, scene_frame),
                          composite(clear, cave, eye, scene_frame), system.read_particles(),
                          np.array(scene_frame.rotor.hub))
    finally:
        for r in (*renderers.values(), *clear.values()):
            r.release()
        system.release()
        empty.release()
    return out


def cloud_mask(picture: Image.Image, clear: Image.Image) -> np.ndarray:
    """Pixels the dust changed by more than DUST_LEVELS in any channel."""
    a = np.asarray(picture, dtype=np.int16)
    b = np.asarray(clear, dtype=np.int16)
    return np.abs(a - b).max(axis=2) > DUST_LEVELS


def connected_share(mask: np.ndarray) -> float:
    """The largest 4-connected region's share of the masked pixels (0 without any)."""
    total = int(mask.sum())
    if total == 0:
        return 0.0
    labels = np.where(mask, np.arange(mask.size).reshape(mask.shape) + 1, 0)
    while True:  # every pixel takes its neighbours' largest label until nothing changes
        grown = labels.copy()
        grown[1:] = np.maximum(grown[1:], labels[:-1])
        grown[:-1] = np.maximum(grown[:-1], labels[1:])
        grown[:, 1:] = np.maximum(grown[:, 1:], labels[:, :-1])
        grown[:, :-1] = np.maximum(grown[:, :-1], labels[:, 1:])
        grown = np.where(mask, grown, 0)
        if np.array_equal(grown, labels):
            break
        labels = grown
    return float(np.bincount(labels[mask]).max() / total)


def azimuth_cv(positions: np.ndarray, hub: np.ndarray, bins: int = AZIMUTH_BINS) -> float:
    """Coefficient of variation of the particle counts in equal azimuth sectors around
    the hub's axis."""
    d = positions[:, :2] - hub[:2]
    angle = np.arctan2(d[:, 1], d[:, 0])
    counts = np.histogram(angle, bins=bins, range=(-np.pi, np.pi))[0].astype(float)
    return float(counts.std() / counts.mean()) if counts.mean() > 0 else float("inf")
