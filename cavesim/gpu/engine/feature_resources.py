"""A scene's features on one GL context: their data, their textures and their uniforms.

The engine asks each feature of the scene (`cavesim.core.features.registry.features_of`)
for what it declares and names none itself: the data it loads once (a grid, a height
field, per-class constants), the textures made from it (each checked against the context's
limits, bound to a unit of its own), the particle pass's constants and what changes each
frame.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import moderngl
import numpy as np

from cavesim.core.features.feature import FrameState, Texture
from cavesim.core.features.registry import FeatureData, features_of
from cavesim.core.scene.model import Scene
from cavesim.gpu.engine.capacity import check_texture

TextureFactory = Callable[[str, Texture], moderngl.Texture | moderngl.Texture3D]


class FeatureResources:
    """The scene's features, their data by name (`data`) and their textures by name with
    the unit each is bound to (`units`)."""

    def __init__(self, ctx: moderngl.Context, scene: Scene, random: np.ndarray | None,
                 make_texture: TextureFactory, first_unit: int) -> None:
        self.features = features_of(scene)
        self.data = FeatureData(scene, random)
        self.units: dict[str, int] = {}
        for feature in self.features:
            for texture in feature.textures(scene, self.data[feature.name]):
                check_texture(ctx.info, texture)
                make_texture(texture.name, texture)
                self.units[texture.name] = first_unit + len(self.units)

    def uniforms(self, scene: Scene) -> dict[str, Any]:
        """The particle pass's constants, and what the frames change as it is before the
        first."""
        values: dict[str, Any] = {}
        for feature in self.features:
            values |= feature.uniforms(scene, self.data[feature.name])
        return values | self.frame_uniforms(scene, None)

    def frame_uniforms(self, scene: Scene, state: FrameState | None) -> dict[str, Any]:
        """What changes this frame (None: before the first)."""
        values: dict[str, Any] = {}
        for feature in self.features:
            values |= feature.frame_uniforms(scene, self.data[feature.name], state)
        return values

    def reseed(self, scene: Scene, random: np.ndarray | None) -> dict[str, Any]:
        """The constants of the features that draw from the random texture, whose words a
        new seed changed (their data loaded again)."""
        values: dict[str, Any] = {}
        for feature in self.features:
            if feature.draws_random:
                self.data.reload(feature, scene, random)
                values |= feature.uniforms(scene, self.data[feature.name])
        return values
