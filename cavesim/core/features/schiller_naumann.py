"""Drag beyond Stokes: Schiller & Naumann's law for classes whose particle Reynolds number
nears one (cavesim/core/drag.py holds the law). A class names its law ([[particle_class]]
drag), or the loader gives it the one its Reynolds number at the scene's speeds asks for
(`chosen_law`): Schiller-Naumann where it reaches STOKES_REYNOLDS_LIMIT, Stokes below,
where it is within 5% and cheaper (its code is compiled out of a scene with no such class).
It scales drag's rate by 1 + 0.15 Re^0.687 (shaders/include/forces.glsl,
HAS_SCHILLER_NAUMANN).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from cavesim.core.drag import STOKES_REYNOLDS_LIMIT, terminal_speed
from cavesim.core.features.feature import Feature
from cavesim.core.features.rules import Rule
from cavesim.core.limits import ROTOR_SPEED_RANGE
from cavesim.core.scene.model import DragLaw, Field, FieldKind, Helicopter, Motion, ParticleClass


class SchillerNaumann(Feature):
    name = "schiller_naumann"
    keys = ("particle_class.drag",)
    defines = {"HAS_SCHILLER_NAUMANN": (0, 1)}
    rules = (Rule("HAS_SCHILLER_NAUMANN", "HAS_DRAG", "particle_class[].drag",
                  "a drag law acts through forces.drag, which is missing"),)

    def present(self, scene):
        return any(c.drag is DragLaw.SCHILLER_NAUMANN for c in scene.particle_classes)

    def complete(self, scene):
        """Each inertial class with its drag law: its own, else the one its Reynolds number
        asks for (`chosen_law`); a tracer has none, nor a class without drag."""
        drag = scene.forces.drag
        if drag is None:
            return scene
        gravity = math.hypot(*scene.forces.gravity) if scene.forces.gravity is not None else 0.0
        flow = flow_scales(scene.field, scene.helicopter)
        classes = tuple(
            c if c.drag is not None or c.motion is Motion.TRACER else dataclasses.replace(
                c, drag=chosen_law(c, drag.kinematic_viscosity, drag.air_viscosity, gravity,
                                   flow))
            for c in scene.particle_classes)
        return dataclasses.replace(scene, particle_classes=classes)

    def where(self, scene, key):
        index = next(i for i, c in enumerate(scene.particle_classes)
                     if c.drag is DragLaw.SCHILLER_NAUMANN)
        return f"particle_class[{index}].drag", DragLaw.SCHILLER_NAUMANN.value

    def load(self, scene, random):
        """d / nu of each class (Re = this × |u - v|), 0 for a Stokes one, float32."""
        return np.array(scene.reynolds_per_speed(), dtype=np.float32)

    def uniforms(self, scene, data):
        # four classes to a vec4: (CLASS_COUNT + 3) / 4 of them (shaders/include/forces.glsl)
        return {"reynolds_per_speed": np.pad(data, (0, -len(data) % 4))}

    def force_terms(self, scene, data, kernels, class_id, state):
        index = np.minimum(class_id, len(data) - 1)
        return {"reynolds_per_speed": data[index].astype(kernels.dtype)[:, None]}


SCHILLER_NAUMANN = SchillerNaumann()


def flow_scales(field: Field | None, helicopter: Helicopter | None) -> tuple[float, float]:
    """(U, L): the largest flow speed a scene's field reaches (m/s) and the length over which
    it changes (m); (0, inf) where the loader cannot tell without reading a file's data."""
    if field is None:
        return 0.0, math.inf
    p = field.params
    if field.kind is FieldKind.UNIFORM:
        return math.hypot(*p["velocity"]), math.inf
    if field.kind is FieldKind.VORTEX:
        swirl = abs(p["circulation"]) / (2 * math.pi * p["core_radius"])
        return max(swirl, abs(p["axial_speed"])), p["core_radius"]
    if field.kind is FieldKind.DOWNWASH:
        return 2.0 * p["induced_velocity"], p["rotor_radius"]
    if field.kind is FieldKind.ROTOR:  # the far wake, 2 v_i, at the fastest rotor speed
        hover = math.sqrt(helicopter.weight / (2 * helicopter.air_density
                                               * helicopter.disk_area))
        return 2.0 * ROTOR_SPEED_RANGE[1] * hover, helicopter.rotor_radius
    return 0.0, math.inf


def slip_scale(tau: float, settling: float, flow_speed: float, flow_length: float) -> float:
    """The slip a class keeps at a scene's speeds: its settling speed, or the lag
    U St / (1 + St) of a first-order response to a flow that changes by U over L
    (Stokes number St = tau U / L), whichever is larger."""
    stokes_number = tau * flow_speed / flow_length
    return max(settling, flow_speed * stokes_number / (1.0 + stokes_number))


def chosen_law(particle: ParticleClass, nu: float, mu: float, gravity: float,
               flow: tuple[float, float]) -> DragLaw:
    """Schiller-Naumann where the class's Reynolds number at its slip scale reaches
    STOKES_REYNOLDS_LIMIT, else Stokes (compiled out: cheaper, and exact there)."""
    settling = terminal_speed(particle, False, nu, mu, gravity)
    slip = slip_scale(particle.relaxation_time(mu), settling, *flow)
    reynolds = slip * particle.diameter / nu
    return DragLaw.SCHILLER_NAUMANN if reynolds >= STOKES_REYNOLDS_LIMIT else DragLaw.STOKES
