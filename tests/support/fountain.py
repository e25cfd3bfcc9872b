"""config/scenes/minimal.toml's fountain with births and deaths every frame, and the clock
that steps it: what the trajectory tests follow."""

import tomllib
from pathlib import Path

import numpy as np

from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import parse_scene

DT = 1 / 60
MINIMAL = Path(__file__).parents[2] / "config/scenes/minimal.toml"


def fountain(rate=300.0, capacity=10_000, lifetime=(0.1, 0.4)):
    """The minimal scene's fountain at `rate`, its drops living `lifetime` seconds."""
    with open(MINIMAL, "rb") as f:
        data = tomllib.load(f)
    data["simulation"]["capacity"] = capacity
    data["emitter"][0].update(rate=rate, lifetime=list(lifetime))
    return parse_scene(data, name="fountain")


def frames(scene, count, seed=1):
    """`count` frames of DT with the clock's random-texture maps, numbered from 1."""
    rng = np.random.default_rng(seed)
    for k in range(1, count + 1):
        yield k, FrameInput(DT, draw_transform(rng, scene.random_texture_size))


def steps(twin, count, seed=1):
    """Step `twin` `count` frames, yielding each frame's number after its step."""
    for k, frame in frames(twin.scene, count, seed):
        twin.step(frame)
        yield k
