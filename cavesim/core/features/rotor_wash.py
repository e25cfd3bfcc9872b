"""The helicopter's downwash as the flow ([field] kind = "rotor"): no grid, evaluated per
particle from the frame's rotor hub and induced velocity, which the master makes once for
every node (cavesim/core/helicopter/downwash.py holds its physics and validation; the GPU's
is shaders/include/rotor.glsl, FIELD_IS_ROTOR; the portable twin's
cavesim/core/portable/rotor.py). A scene with it has a [helicopter] (the loader's rule).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import Feature
from cavesim.core.features.rules import Rule
from cavesim.core.helicopter.downwash import downwash
from cavesim.core.helicopter.flight import ground_height
from cavesim.core.portable import rotor as portable_rotor
from cavesim.core.scene.model import FieldKind


class RotorWash(Feature):
    name = "rotor_wash"
    keys = ()  # a value of a key, not a key: [field] kind = "rotor"
    defines = {"FIELD_IS_ROTOR": (0, 1)}
    rules = (Rule("FIELD_IS_ROTOR", "HAS_DRAG", "field.kind",
                  "the rotor's flow acts through forces.drag"),)
    include = "rotor.glsl"

    def present(self, scene):
        return scene.field is not None and scene.field.kind is FieldKind.ROTOR

    def uniforms(self, scene, data):
        """The rotor's size and the ground it blows against."""
        return {"rotor_radius": np.float32(scene.helicopter.rotor_radius),
                "rotor_ground_z": np.float32(ground_height(scene))}

    def frame_uniforms(self, scene, data, state):
        if state is None or state.rotor is None:  # before the first frame: nothing blows
            return {}
        return {"rotor_hub": state.rotor.hub, "induced_velocity": state.rotor.induced_velocity}

    def force_terms(self, scene, data, kernels, class_id, state):
        rotor = state.rotor
        if rotor is None:  # outside a frame: no wash
            return {}
        radius, ground_z = scene.helicopter.rotor_radius, np.float32(ground_height(scene))
        if kernels.portable:
            def flow(p, stage):
                return portable_rotor.flow_at(p, rotor.hub, float(rotor.induced_velocity),
                                              radius, ground_z)
        else:
            def flow(p, stage):
                return downwash(p, rotor.hub, float(rotor.induced_velocity), radius, ground_z,
                                dtype=kernels.dtype)
        return {"flow": flow}


ROTOR_WASH = RotorWash()
