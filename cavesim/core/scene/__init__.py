"""Scenes: the typed description of one simulated world and its TOML loader.

`load_scene("config/scenes/dust_devil.toml")` is where a scene enters; the engine, the
shader specializer and the numpy twin only ever see the frozen objects re-exported here.
"""

from cavesim.core.features.collision import Collision, CollisionKind
from cavesim.core.features.dispersion import Dispersion
from cavesim.core.features.stokes_drag import Drag
from cavesim.core.scene.loader import load_scene, parse_scene
from cavesim.core.scene.model import (
    AIR_VISCOSITY,
    Arithmetic,
    DragLaw,
    Emitter,
    Engine,
    Field,
    FieldInterpolation,
    FieldKind,
    FieldSampling,
    Forces,
    Helicopter,
    Integrator,
    Motion,
    OutOfDomain,
    ParticleClass,
    Scene,
    TracerMethod,
    Vec3,
    WandKey,
)

__all__ = [
    "AIR_VISCOSITY",
    "Arithmetic",
    "Collision",
    "CollisionKind",
    "Dispersion",
    "Drag",
    "DragLaw",
    "Emitter",
    "Engine",
    "Field",
    "FieldInterpolation",
    "FieldKind",
    "FieldSampling",
    "Forces",
    "Helicopter",
    "Integrator",
    "Motion",
    "OutOfDomain",
    "ParticleClass",
    "Scene",
    "TracerMethod",
    "Vec3",
    "WandKey",
    "load_scene",
    "parse_scene",
]
