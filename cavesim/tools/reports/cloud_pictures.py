"""The brownout cloud in pictures and numbers (README: the brownout demo's before/after).

The walls of a helicopter scene at chosen frames (`scene_pictures.draw_walls`), unfolded
into one composite. The measures: along the horizon, the share of the band just above it
that the dust covers, column by column (separate puffs leave gaps, one cloud none); the
share of the sky the dust covers (a cloud that rises, not a sheet on the ground); and the
coefficient of variation of the dust's particle counts binned by azimuth around the rotor
(large for puffs, small for a ring of cloud).
"""

from __future__ import annotations

import moderngl
import numpy as np
from PIL import Image

from cavesim.core.cave.geometry import Cave
from cavesim.core.scene.model import Scene
from cavesim.gpu.render.composite import compose
from cavesim.gpu.render.wall_renderer import RenderSettings
from cavesim.tools.reports.scene_pictures import DUST_LEVELS, draw_walls

SKY_LEVELS = 3  # a pixel of the view without dust is sky within this of a sky colour
BAND_SHARE = 0.05  # the band above the horizon: this share of the picture's height
COVERED = 0.25  # a column is clouded where dust covers this share of its band
AZIMUTH_BINS = 24


def play(ctx: moderngl.Context, scene: Scene, cave: Cave, at: set[int]
         ) -> dict[int, tuple[Image.Image, Image.Image, np.ndarray, np.ndarray]]:
    """Frame k -> (composite, the same view without dust, the particles, the rotor hub)."""
    return {k: (compose(cave, walls.pictures), compose(cave, walls.clear), walls.particles,
                np.array(walls.scene_frame.rotor.hub))
            for k, walls in draw_walls(ctx, scene, cave, at).items()}


def cloud_mask(picture: Image.Image, clear: Image.Image) -> np.ndarray:
    """Pixels the dust changed by more than DUST_LEVELS in any channel."""
    a = np.asarray(picture, dtype=np.int16)
    b = np.asarray(clear, dtype=np.int16)
    return np.abs(a - b).max(axis=2) > DUST_LEVELS


def sky(clear: Image.Image) -> np.ndarray:
    """The sky's pixels in the view without dust: those within SKY_LEVELS of a colour of
    its gradient from the horizon to the zenith (the sun and its glow left out)."""
    settings = RenderSettings()
    horizon = np.asarray(settings.sky) * 255.0
    rise = np.asarray(settings.sky_zenith) * 255.0 - horizon
    rgb = np.asarray(clear, dtype=float)
    along = np.clip((rgb - horizon) @ rise / (rise @ rise), 0.0, 1.0)
    return np.abs(rgb - horizon - along[..., None] * rise).max(axis=2) <= SKY_LEVELS


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
