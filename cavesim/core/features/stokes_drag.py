"""Drag toward the flow: a = (u(p) - v) / tau, Stokes' law, each class relaxing at its own
1/tau = 18 mu / (rho_p d²) ([forces.drag]: the air). It brings the flow in: a scene with
drag has a [field] (the loader's rule), whose kind is a feature of its own (`grid_flow`,
`rotor_wash`). A term of the force law (shaders/include/forces.glsl, HAS_DRAG); the
drag laws beyond Stokes scale its rate (`schiller_naumann`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numpy as np

from cavesim.core._schema import Range
from cavesim.core.air import AIR_DENSITY, AIR_VISCOSITY
from cavesim.core.errors import SceneError
from cavesim.core.features.feature import Feature


@dataclass(frozen=True)
class Drag:
    """[forces.drag]: the air the particles move through."""

    air_viscosity: Annotated[float, Range(gt=0.0)] = AIR_VISCOSITY  # mu, Pa·s
    air_density: Annotated[float, Range(gt=0.0, le=10.0)] = AIR_DENSITY  # kg/m³

    @property
    def kinematic_viscosity(self) -> float:
        """nu = mu / rho_air in m²/s."""
        return self.air_viscosity / self.air_density


class StokesDrag(Feature):
    name = "stokes_drag"
    keys = ("forces.drag",)
    defines = {"HAS_DRAG": (0, 1)}

    def present(self, scene):
        return scene.forces.drag is not None

    def check(self, scene):
        """Drag brings the flow in, and only drag samples it: a [field] exactly with it."""
        source = scene.source or "<dict>"
        if self.present(scene) and scene.field is None:
            raise SceneError(f"{source}: field is missing: required because forces.drag is "
                             "present (drag pulls particles toward the [field] flow)")
        if not self.present(scene) and scene.field is not None:
            raise SceneError(f"{source}: field (kind = {scene.field.kind.value!r}) is not "
                             "allowed: only together with forces.drag, which is missing "
                             "(without drag nothing samples the field)")

    def load(self, scene, random):
        """1/tau of each class, float32 (0 for a tracer, which drag never steps)."""
        return np.array(scene.inverse_relaxation_times(), dtype=np.float64).astype(np.float32)

    def uniforms(self, scene, data):
        return {"inv_tau": data}

    def force_terms(self, scene, data, kernels, class_id, state):
        index = np.minimum(class_id, len(data) - 1)
        return {"inv_tau": data[index].astype(kernels.dtype)[:, None]}


STOKES_DRAG = StokesDrag()
