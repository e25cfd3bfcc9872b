"""Small scenes for the engine tests, built as dicts and validated by the real loader."""

from __future__ import annotations

import copy

import numpy as np

from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene

SAND = {"name": "sand", "diameter": 400e-6, "density": 2650.0}  # tau ~ 1.3 s
DUST = {"name": "dust", "diameter": 100e-6, "density": 2650.0}  # tau ~ 0.08 s
SMOKE = {"name": "smoke", "diameter": 1e-5, "motion": "tracer"}  # a passive tracer

VORTEX_FIELD = {
    "kind": "vortex", "box_min": [-4.0, -4.0, 0.0], "box_max": [4.0, 4.0, 4.0],
    "resolution": [17, 17, 9],
    "params": {"center": [0.3, -0.2], "circulation": 20.0, "core_radius": 1.0,
               "axial_speed": 0.5},
}

FOUNTAIN = {
    "name": "fountain", "position": [0.0, 0.0, 0.5], "extent": [1.0, 1.0, 0.2],
    "rate": 600.0, "speed": 3.0, "speed_spread": 1.0, "direction": [0.2, 0.0, 1.0],
    "spread_angle": 25.0, "lifetime": [0.5, 1.5], "particle_class": "sand",
}


def scene_dict(integrator="semi_implicit_euler", capacity=4000, emitters=(), drag=True,
               gravity=True, damping=None, collision=None, field=None, seed=7,
               engine="gs_tf", arithmetic="native", dispersion=None) -> dict:
    """A scene dict: sand and dust in a vortex with the chosen features (`dispersion`: a
    [forces.dispersion] table, which needs a collision)."""
    data = {
        "simulation": {"capacity": capacity, "seed": seed, "integrator": integrator,
                       "random_texture_size": 64, "engine": engine, "arithmetic": arithmetic},
        "particle_class": [SAND, DUST],
        "emitter": [copy.deepcopy(e) for e in emitters],
        "forces": {},
    }
    if gravity:
        data["forces"]["gravity"] = [0.0, 0.0, -9.81]
    if damping is not None:
        data["forces"]["damping"] = damping
    if drag:
        data["forces"]["drag"] = {}
        data["field"] = copy.deepcopy(field or VORTEX_FIELD)
    if collision is not None:
        data["collision"] = collision
    if dispersion is not None:
        data["forces"]["dispersion"] = dispersion
    return data


def make_scene(**kwargs):
    return parse_scene(scene_dict(**kwargs), name="test")


def with_smoke(data: dict) -> dict:
    """The scene dict with its dust (class 1) a passive tracer, smoke, instead."""
    data = copy.deepcopy(data)
    data["particle_class"] = [dict(data["particle_class"][0]), dict(SMOKE)]
    for emitter in data["emitter"]:
        if emitter["particle_class"] == DUST["name"]:
            emitter["particle_class"] = SMOKE["name"]
    return data


def particle_cloud(count: int, seed: int = 0, box=((-3, -3, 0.5), (3, 3, 3.5))) -> np.ndarray:
    """A fixed particle set that lives forever: positions in `box`, random velocities."""
    rng = np.random.default_rng(seed)
    records = np.zeros(count, dtype=PARTICLE_DTYPE)
    records["pos"] = rng.uniform(box[0], box[1], size=(count, 3))
    records["vel"] = rng.normal(0.0, 1.0, size=(count, 3))
    records["lifetime"] = 1e6
    records["class_id"] = np.arange(count) % 2
    return records
