"""The brownout demo's cloud, measured in its pictures: one continuous cloud around the
helicopter that the wash's turbulence lifts off the ground, where separate puffs (README:
the brownout demo, before and after) left gaps along the horizon; without the walk the
dust stays a carpet in the wall jet, below the horizon."""

import dataclasses

import numpy as np
import pytest

from cavesim.core.cave.geometry import load_cave
from cavesim.core.scene import load_scene
from cavesim.tools.reports.cloud_pictures import (
    azimuth_cv,
    band_measures,
    horizon_band,
    play,
    sky_coverage,
)

FRAME = 720  # hovering low over the landing spot, the cloud grown for 7 s
WALL_SCALE = 1 / 3  # the default CAVE's 480 px walls at 160 px


@pytest.mark.slow
def test_the_brownout_cloud_is_one_cloud_that_rises(ctx):
    scene = load_scene("config/scenes/brownout.toml")
    still = dataclasses.replace(scene, forces=dataclasses.replace(scene.forces,
                                                                  dispersion=None))
    cave = load_cave("config/cave/flex4.toml").scaled(WALL_SCALE)
    dust = [c.name for c in scene.particle_classes].index("dust")
    measured = {}
    for name, each in (("walk", scene), ("still", still)):
        picture, clear, records, hub = play(ctx, each, cave, {FRAME})[FRAME]
        coverage, variation = band_measures(horizon_band(picture, clear))
        positions = records["pos"][records["class_id"] == dust]
        measured[name] = {"coverage": coverage, "variation": variation,
                          "sky": sky_coverage(picture, clear),
                          "azimuth": azimuth_cv(positions, hub),
                          "height": float(np.median(positions[:, 2]))}
    walk, still = measured["walk"], measured["still"]
    assert walk["coverage"] > 0.9 and walk["variation"] < 0.5, walk  # no gaps, no puffs
    assert walk["azimuth"] < 0.15, walk  # a ring all round the rotor
    assert still["coverage"] < 0.1 and still["sky"] < 0.05, still  # a carpet on the ground
    assert walk["sky"] > still["sky"] + 0.15 and walk["height"] > 3 * still["height"], measured
