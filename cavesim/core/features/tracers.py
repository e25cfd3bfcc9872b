"""Passive tracers: classes that move with the flow, dx/dt = u(x, t), with no inertia,
gravity or damping ([[particle_class]] motion = "tracer"), stepped by an explicit
Runge-Kutta method of the TracerMethod table: the integrator's own form without inertia,
or [simulation] tracer_method, "rk45" in substeps held to tracer_tolerance
(cavesim/core/substeps.py). The GPU's code is shaders/include/tracers.glsl (HAS_TRACERS,
TRACER_METHOD); the twins' are cavesim/core/twin/tracers.py and
cavesim/core/portable/tracers.py. A tracer moves with the flow that drag brings in, and
dispersion's random walk is drag's: a scene has tracers or dispersion.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.errors import SceneError
from cavesim.core.features.feature import Feature
from cavesim.core.features.rules import Rule
from cavesim.core.scene.model import Motion, TracerMethod
from cavesim.core.substeps import stage_nodes, tableau


class Tracers(Feature):
    name = "tracers"
    keys = ("particle_class.motion", "simulation.tracer_method",
            "simulation.tracer_tolerance")
    ids = {f"TRACER_{m.name}": m.gpu_id for m in TracerMethod}
    defines = {"HAS_TRACERS": (0, 1),
               "TRACER_METHOD": tuple(sorted(m.gpu_id for m in TracerMethod))}
    rules = (
        Rule("HAS_TRACERS", "HAS_DRAG", "particle_class[].motion",
             '"tracer" needs forces.drag and a [field]: the flow that carries it'),
        Rule("HAS_TRACERS", "!HAS_DISPERSION", "particle_class[].motion",
             '"tracer" is not allowed with forces.dispersion: its random walk acts through '
             'drag (allowed: "inertial")'),
        Rule("TRACER_METHOD != TRACER_EULER", "HAS_TRACERS", "simulation.tracer_method",
             'only with a [[particle_class]] of motion = "tracer"'),
    )
    include = "tracers.glsl"

    def present(self, scene):
        return any(scene.tracer_classes)

    def where(self, scene, key):
        if key == "simulation.tracer_method":
            return key, scene.tracer_method.value
        index = scene.tracer_classes.index(True)
        return f"particle_class[{index}].motion", Motion.TRACER.value

    def check(self, scene):
        if scene.tracer_method is not None and not self.present(scene):
            raise SceneError(f"{scene.source or '<dict>'}: simulation.tracer_method = "
                             f"{scene.tracer_method.value!r} is not allowed: only with a "
                             '[[particle_class]] of motion = "tracer": no class of this scene '
                             "is one")

    def define_values(self, scene):
        return {"HAS_TRACERS": 1, "TRACER_METHOD": scene.method_for_tracers.gpu_id}

    def uniforms(self, scene, data):
        # uvec2: bit c of the 64 for class c
        bits = sum(1 << c for c, tracer in enumerate(scene.tracer_classes) if tracer)
        values = {"tracer_classes": np.array([bits & 0xFFFFFFFF, bits >> 32], dtype=np.uint32)}
        if scene.tracers_take_substeps:  # Dormand-Prince's coefficients, the tolerance
            values |= {"rk45_tableau": tableau(np.float32),
                       "rk45_nodes": stage_nodes(np.float32)[1:5],
                       "tracer_tolerance": np.float32(scene.tracer_tolerance)}
        return values


TRACERS = Tracers()
