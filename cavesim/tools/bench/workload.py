"""The benchmark's workload: a full pool of long-lived particles and the frames that step it.

Everything is drawn from PCG64 seeded by the scene's seed and the size, so two runs of the
benchmark (and the GPU and numpy paths of one run) step exactly the same particles.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.drivers import driver_for
from cavesim.core.features.collision import CollisionKind
from cavesim.core.fields.heights import HeightGrid
from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import draw_transform
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene.model import Scene
from cavesim.core.scene_frame import SceneFrame

FRAME_DT = 1 / 60  # s
LIFETIME = 1e6  # s: no particle dies while measured, so every frame moves the full pool
SPEED_MAX = 0.5  # m/s per axis: small random velocities, uniform in +-SPEED_MAX
CUBE_EDGE = 10.0  # m: where particles start when the scene has no field box
# Particles drawn at a time, as float32 uniforms: at 53M particles, float64 and normal draws of
# the whole pool took 9-10 s on two cores, these 4-6 s, most of it first writes into 2 GB
PRELOAD_CHUNK = 1 << 20


def preload(scene: Scene, count: int, ground: HeightGrid | None) -> np.ndarray:
    """`count` particles (PARTICLE_DTYPE) spread over the field box, else a cube above ground."""
    rng = np.random.Generator(np.random.PCG64([scene.seed, count]))
    if scene.field is not None:
        low = np.array(scene.field.box_min, dtype=np.float32)
        high = np.array(scene.field.box_max, dtype=np.float32)
    else:
        low = np.array([-CUBE_EDGE / 2, -CUBE_EDGE / 2, ground_level(scene, ground)],
                       dtype=np.float32)
        high = low + np.float32(CUBE_EDGE)
    records = np.zeros(count, dtype=PARTICLE_DTYPE)
    for start in range(0, count, PRELOAD_CHUNK):
        chunk = records[start:start + PRELOAD_CHUNK]
        chunk["pos"] = low + (high - low) * rng.random((len(chunk), 3), dtype=np.float32)
        chunk["vel"] = SPEED_MAX * (2 * rng.random((len(chunk), 3), dtype=np.float32) - 1)
    records["lifetime"] = LIFETIME
    records["class_id"] = np.arange(count, dtype=np.uint32) % max(1, len(scene.particle_classes))
    return records


def ground_level(scene: Scene, ground: HeightGrid | None) -> float:
    """Height of the scene's ground (the top of a height field), 0 without collision."""
    if scene.collision is None:
        return 0.0
    if scene.collision.kind is CollisionKind.PLANE:
        return scene.collision.height
    return float(ground.height.max())


def frame_inputs(scene: Scene, count: int) -> list[tuple[FrameInput, SceneFrame]]:
    """`count` frames at 60 Hz, each with its own random-texture transform, and the scene's
    state as a node decodes it from the master's driver (a helicopter flies its timeline)."""
    rng = np.random.Generator(np.random.PCG64([scene.seed, 1]))
    driver = driver_for(scene)
    frames = []
    for k in range(1, count + 1):
        state = driver.advance(k * FRAME_DT, FRAME_DT, None).frame
        frames.append((FrameInput(FRAME_DT, draw_transform(rng, scene.random_texture_size)),
                       driver.decode(driver.encode(state))))
    return frames
