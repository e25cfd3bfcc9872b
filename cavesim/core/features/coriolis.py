"""The Coriolis acceleration: a = -2 Omega x v in a frame that turns at Omega ([forces]
coriolis, rad/s): inertial particles in a geophysical flow given in the Earth's frame. A
term of the force law (shaders/include/forces.glsl, HAS_CORIOLIS), which the exponential
integrators hold explicitly over a step, as they hold the flow. A tracer has no inertia:
the flow it follows already holds the Earth's turning.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature


class Coriolis(Feature):
    name = "coriolis"
    keys = ("forces.coriolis",)
    defines = {"HAS_CORIOLIS": (0, 1)}

    def present(self, scene):
        return scene.forces.coriolis is not None

    def uniforms(self, scene, data):
        return {"frame_rotation": np.array(scene.forces.coriolis, dtype=np.float32)}

    def force_terms(self, scene, data, kernels, class_id, state):
        return {"frame_rotation": self.uniforms(scene, data)["frame_rotation"]
                .astype(kernels.dtype)}


CORIOLIS = Coriolis()
