"""The brownout cloud in pictures and numbers (README: the brownout demo's before/after).

One GL context plays a helicopter scene with the master's inputs (its driver's frames, a
random transform per frame from the clock seed) and draws every wall of a CAVE at chosen
frames, unfolded into one composite, as `cavesim run` would (the walls of a run hold
the same bits). The measures: along the horizon, the share of the band just above it
that the dust covers, column by column (separate puffs leave gaps, one cloud none); the
share of the sky the dust covers (a cloud that rises, not a sheet on the ground); and the
coefficient of variation of the dust's particle counts binned by azimuth around the rotor
(large for puffs, small for a ring of cloud).
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
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.composite import compose
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer

FRAME_DT = 1 / 60
CLOCK_SEED = 7  # the transforms' generator, as a master's clock seed
DUST_LEVELS = 12  # a pixel is cloud where dust changed it by more than this (of 255)
SKY_LEVELS = 3  # a pixel of the view without dust is sky within this of the sky colour
BAND_SHARE = 0.05  # the band above the horizon: this share of the picture's height
COVERED = 0.25  # a column is clouded where dust covers this share of its band
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


def sky(clear: Image.Image) -> np.ndarray:
    """The sky's pixels in the view without dust."""
    colour = np.asarray(RenderSettings().sky) * 255.0
    return np.abs(np.asarray(clear, dtype=float) - colour).max(axis=2) <= SKY_LEVELS


def horizon_band(picture: Image.Image, clear: Image.Image) -> np.ndarray:
    """Per column that shows sky: the share of the band of BAND_SHARE of the picture's
    height up to its horizon (its lowest sky pixel) that the dust changed."""
    mask, is_sky = cloud_mask(picture, clear), sky(clear)
    rows = max(1, round(BAND_SHARE * mask.shape[0]))
    shares = []
    for column in np.flatnonzero(is_sky.any(axis=0)):
        horizon = np.flatnonzero(is_sky[:, column]).max()
        shares.append(mask[max(0, horizon + 1 - rows):horizon + 1, column].mean())
    return np.array(shares)


def sky_coverage(picture: Image.Image, clear: Image.Image) -> float:
    """The share of the sky the dust covers."""
    return float(cloud_mask(picture, clear)[sky(clear)].mean())


def band_measures(shares: np.ndarray) -> tuple[float, float]:
    """(coverage, CV): the share of columns at least COVERED clouded along the horizon, and
    the coefficient of variation of the columns' clouded shares."""
    return float((shares >= COVERED).mean()), float(shares.std() / max(shares.mean(), 1e-9))


def azimuth_cv(positions: np.ndarray, hub: np.ndarray, bins: int = AZIMUTH_BINS) -> float:
    """Coefficient of variation of the particle counts in equal azimuth sectors around
    the hub's axis."""
    d = positions[:, :2] - hub[:2]
    angle = np.arctan2(d[:, 1], d[:, 0])
    counts = np.histogram(angle, bins=bins, range=(-np.pi, np.pi))[0].astype(float)
    return float(counts.std() / counts.mean()) if counts.mean() > 0 else float("inf")
