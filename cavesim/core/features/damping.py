"""Damping: a = -k v, a linear loss of speed at the rate k ([forces] damping, 1/s). A term of
the force law and of the linear part the exponential integrators hold over a step
(shaders/include/forces.glsl, HAS_DAMPING)."""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature


class Damping(Feature):
    name = "damping"
    keys = ("forces.damping",)
    defines = {"HAS_DAMPING": (0, 1)}

    def present(self, scene):
        return scene.forces.damping is not None

    def uniforms(self, scene, data):
        return {"damping": np.float32(scene.forces.damping)}

    def force_terms(self, scene, data, kernels, class_id, state):
        return {"damping": kernels.dtype(np.float32(scene.forces.damping))}


DAMPING = Damping()
