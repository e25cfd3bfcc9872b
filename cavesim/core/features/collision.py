"""The ground and the bounce off it ([collision]): a plane at a height, or a height field's
terrain (an .npz of heights over a box), which particles cannot pass. A particle below it
after a step is pushed back onto it, and one heading in bounces, v' = (1 - nu) v_t -
epsilon v_n, with no friction below a small speed (Kolb et al.). The GPU's code is
shaders/include/collision.glsl (COLLISION; the terrain: heightfield.glsl); the twins' are
cavesim/core/twin/collision.py and cavesim/core/portable/ground.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import numpy as np

from cavesim.core._schema import Coordinate, Range
from cavesim.core.features.feature import Feature, Texture
from cavesim.core.fields.heights import HeightGrid, load_heightfield
from cavesim.core.portable import ground as portable_ground
from cavesim.core.twin import collision as twin_collision


class CollisionKind(StrEnum):
    PLANE = "plane"  # flat ground at `height`
    HEIGHTFIELD = "heightfield"  # terrain heights from `file`


@dataclass(frozen=True)
class Collision:
    kind: CollisionKind
    # ν: share of tangential speed lost at a bounce
    friction: Annotated[float, Range(ge=0.0, le=1.0)]
    # ε: share of normal speed kept at a bounce
    resilience: Annotated[float, Range(ge=0.0, le=1.0)]
    # m/s: below this speed no friction is applied
    friction_min_speed: Annotated[float, Range(ge=0.0)] = 0.0
    height: Annotated[float, Coordinate("z")] = 0.0  # PLANE: ground height z
    # HEIGHTFIELD: .npz with "height" (nx, ny), "box_min", "box_max" in world coordinates
    file: Path | None = None


class Ground(Feature):
    name = "collision"
    keys = ("collision",)
    ids = {"COLLISION_NONE": 0, "COLLISION_PLANE": 1, "COLLISION_HEIGHTFIELD": 2}
    defines = {"COLLISION": (0, 1, 2)}
    include = "collision.glsl"

    def present(self, scene):
        return scene.collision is not None

    def define_values(self, scene):
        return {"COLLISION": self.ids[f"COLLISION_{scene.collision.kind.name}"]}

    def load(self, scene, random) -> HeightGrid | None:
        """The height field's terrain, its box moved by the scene's origin (None: a plane)."""
        if scene.collision.kind is CollisionKind.HEIGHTFIELD:
            return load_heightfield(scene.collision.file, scene.origin)
        return None

    def textures(self, scene, data):
        if data is None:
            return ()
        return (Texture("ground_height", data.height[:, :, np.newaxis],
                        what="the height field's texture", fewer="nodes"),)

    def uniforms(self, scene, data):
        collision = scene.collision
        values = {"friction": np.float32(collision.friction),
                  "resilience": np.float32(collision.resilience),
                  "friction_min_speed": np.float32(collision.friction_min_speed)}
        if data is None:
            return values | {"ground_z": np.float32(collision.height)}
        return values | {"ground_box_min": np.array(data.box_min, dtype=np.float32),
                         "ground_index_scale": data.index_scale}

    def after_move(self, scene, data, kernels, pos, vel):
        collide = portable_ground.collide if kernels.portable else twin_collision.collide
        return collide(pos, vel, scene.collision, data)

    def ground_at(self, scene, data, kernels, xy: np.ndarray) -> np.ndarray:
        """The ground's height (N,) under points (N, 2), in the arithmetic of `kernels`."""
        if kernels.portable:
            return portable_ground.ground_at(scene.collision, data, xy)[0]
        return twin_collision.ground(scene.collision, data, xy, kernels.dtype)[0]


COLLISION = Ground()
