"""Turbulent dispersion: a random walk in the flow each particle sees, with the eddy
diffusivity of Prandtl's mixing length ([forces.dispersion]); the model is in
cavesim/core/twin/dispersion.py, the GPU's in shaders/include/dispersion.glsl
(HAS_DISPERSION), the portable twin's in cavesim/core/portable/dispersion.py.

It acts through drag (the walk is in the flow drag pulls toward) and grows its eddies from
the ground (a collision gives the height), and draws one word of the random texture per
particle and frame at the particle's index, which must not repeat within a frame: the
capacity stays within the texture's words.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numpy as np

from cavesim.core._schema import Range
from cavesim.core.errors import SceneError
from cavesim.core.features.collision import COLLISION
from cavesim.core.features.feature import Feature
from cavesim.core.features.rules import Rule
from cavesim.core.limits import RANDOM_TEXTURE_SIZE_RANGE
from cavesim.core.portable import dispersion as portable_dispersion
from cavesim.core.random_texture import WORDS_PER_TEXEL
from cavesim.core.twin import dispersion as twin_dispersion


@dataclass(frozen=True)
class Dispersion:
    """[forces.dispersion]: turbulent dispersion, a random walk of the flow each particle
    sees with the eddy diffusivity of Prandtl's mixing length (cavesim.core.twin.dispersion)."""

    # m: the largest eddies' size, Blackadar's l_inf of l = kappa z / (1 + kappa z / l_inf)
    mixing_length: Annotated[float, Range(gt=0.0, le=1000.0)]


class TurbulentDispersion(Feature):
    name = "dispersion"
    keys = ("forces.dispersion",)
    # the random texture's size, which its draws address, is the particle pass's only here
    defines = {"HAS_DISPERSION": (0, 1), "RANDOM_SIZE": RANDOM_TEXTURE_SIZE_RANGE}
    rules = (
        Rule("HAS_DISPERSION", "HAS_DRAG", "forces.dispersion",
             "needs forces.drag: the random walk is in the flow each particle sees, which "
             "reaches it through drag"),
        Rule("HAS_DISPERSION", "COLLISION != COLLISION_NONE", "forces.dispersion",
             "needs [collision]: the mixing length grows with the height above the ground"),
        Rule(f"RANDOM_SIZE != {RANDOM_TEXTURE_SIZE_RANGE[0]}", "HAS_DISPERSION",
             "simulation.random_texture_size", "the particle pass reads the random "
             "texture only for dispersion"),
    )
    include = "dispersion.glsl"
    draws_random = True

    def present(self, scene):
        return scene.forces.dispersion is not None

    def define_values(self, scene):
        return {"HAS_DISPERSION": 1, "RANDOM_SIZE": scene.random_texture_size}

    def check(self, scene):
        if not self.present(scene):
            return
        words = WORDS_PER_TEXEL * scene.random_texture_size**2
        if scene.capacity > words:
            raise SceneError(
                f"{scene.source or '<dict>'}: simulation.capacity = {scene.capacity!r} is not "
                f"allowed: must be <= {words} with forces.dispersion: one random word per "
                f"particle a frame, {WORDS_PER_TEXEL} per texel of the "
                f"{scene.random_texture_size}² random texture (raise "
                "simulation.random_texture_size)")

    def load(self, scene, random):
        """The random texture's words and their draws' mean and spread over it."""
        return random, twin_dispersion.draw_moments(random)

    def uniforms(self, scene, data):
        _, (mean, scale) = data
        return {"mixing_length": np.float32(scene.forces.dispersion.mixing_length),
                "draw_mean": mean, "draw_scale": scale}

    def frame_uniforms(self, scene, data, state):
        if state is None:
            return {}
        return {"random_transform": state.frame.random_transform.T}  # its draws move with it

    def seen(self, scene, data, kernels, twin, forces, state):
        random, moments = data
        q = twin.particles
        ground = COLLISION.ground_at(scene, twin.data[COLLISION.name], kernels, q.pos[:, :2])
        xi = twin_dispersion.draws(random, state.frame.random_transform, len(q.age), moments,
                                   kernels.dtype)
        turbulence = portable_dispersion.turbulence if kernels.portable \
            else twin_dispersion.turbulence
        return {"turbulence": turbulence(forces, q.pos, q.vel, ground,
                                         scene.forces.dispersion.mixing_length, xi,
                                         kernels.dtype(state.frame.dt))}


DISPERSION = TurbulentDispersion()
