"""Gravity: a = g, a constant acceleration ([forces] gravity, m/s²). A term of the force law
(shaders/include/forces.glsl, HAS_GRAVITY)."""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature


class Gravity(Feature):
    name = "gravity"
    keys = ("forces.gravity",)
    defines = {"HAS_GRAVITY": (0, 1)}

    def present(self, scene):
        return scene.forces.gravity is not None

    def uniforms(self, scene, data):
        return {"gravity": np.array(scene.forces.gravity, dtype=np.float32)}

    def force_terms(self, scene, data, kernels, class_id, state):
        return {"gravity": self.uniforms(scene, data)["gravity"].astype(kernels.dtype)}


GRAVITY = Gravity()
