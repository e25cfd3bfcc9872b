"""Every shipped scene (config/scenes/*.toml, a new one included) shows its world on every
wall of the default CAVE once its cloud has built up: no whiteout, where dust hides the
ground, sky and horizon; no blank wall; and a helicopter only where the scene has one.

The thresholds, at frame 300 with 96 px walls: a scene whose dust engulfs the viewer hides
0.80 to 1.0 of every wall (the dust devil and the fountain when they stood in the CAVE),
while a cloud seen from outside hides at most 0.27 (the dust devil's column) and the
brownout demo's at frame 720 at most 0.21: WHITEOUT sits between. A wall of one colour
varies by 0 levels; the floor's ground, the least varied wall of every scene with one, by
7.3. A scene without a ground is plain sky where its particles are not: there only the wall
that faces them must vary.
"""

from pathlib import Path

import numpy as np
import pytest

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.cave.geometry import load_cave
from cavesim.core.scene import load_scene
from cavesim.gpu.render import meshes
from cavesim.tools.reports.scene_pictures import draw_walls, variation, whiteout_share

SCENES = sorted((Path(__file__).parents[2] / "config" / "scenes").glob("*.toml"))
FRAME = 300  # 5 s: the clouds built up (the dust devil's whiteout showed from frame 100)
WALL_SCALE = 0.2  # the default CAVE's 480 px walls at 96 px
WHITEOUT = 0.5  # of a wall's pixels, at most, that dust may hide
MIN_VARIATION = 3.0  # grey levels: a wall's standard deviation, at least
SOFTWARE_CAPACITY = 1_000_000  # particles: a larger pool takes seconds a frame on llvmpipe
HELICOPTER_LEVELS = 255 * max(*meshes.HULL, *meshes.DARK)  # the brightest a hull pixel gets:
# sky and sand are brighter in some channel, everywhere


def helicopter_pixels(clear: np.ndarray) -> int:
    """How many pixels of a view without dust are as dark as the helicopter's hull."""
    return int((clear.max(axis=2) <= HELICOPTER_LEVELS).sum())


@pytest.mark.parametrize("path", SCENES, ids=lambda path: path.stem)
def test_a_shipped_scene_shows_its_world_on_every_wall(ctx, path):
    scene = load_scene(path)
    if ctx.extra["kind"] == "software" and scene.capacity > SOFTWARE_CAPACITY:
        pytest.skip(f"{scene.capacity:,} particles: drawn on a GPU (deploy/gpu-check.sh)")
    walls = draw_walls(ctx, scene, load_cave(DEFAULT_CAVE).scaled(WALL_SCALE), {FRAME})[FRAME]
    hidden = {name: round(whiteout_share(picture, walls.clear[name]), 3)
              for name, picture in walls.pictures.items()}
    assert max(hidden.values()) < WHITEOUT, f"whiteout: the share of each wall dust hides {hidden}"
    varied = {name: round(variation(picture), 1) for name, picture in walls.pictures.items()}
    # without a ground (no [collision]) the world is sky wherever its particles are not
    least = min(varied.values()) if scene.collision else max(varied.values())
    assert least > MIN_VARIATION, f"a blank wall: grey level spread {varied}"
    dark = {name: helicopter_pixels(clear) for name, clear in walls.clear.items()}
    if scene.helicopter is None:
        assert walls.scene_frame.helicopter is None and not any(dark.values()), dark
    else:
        assert any(dark.values()), f"the scene's helicopter is in view: {dark}"
