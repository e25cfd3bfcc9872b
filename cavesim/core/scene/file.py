"""The tables of a scene file that the engine never sees as such: the top level, its
[simulation], and the [field.params] of each field kind.

`loader.parse_scene` reads a file through `SceneFile` and flattens it into a `Scene`; the
other tables are the ones in `model.py`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from cavesim.core._schema import Range, Rule
from cavesim.core.limits import MAX_PARTICLES, RANDOM_TEXTURE_SIZE_RANGE
from cavesim.core.scene.model import (
    Arithmetic,
    Collision,
    Emitter,
    Engine,
    Field,
    FieldKind,
    Forces,
    Helicopter,
    Integrator,
    ParticleClass,
    Vec3,
)


def _power_of_two(n: int) -> bool:
    return n & (n - 1) == 0


@dataclass(frozen=True)
class Simulation:
    """[simulation]: `Scene` holds its values."""

    capacity: Annotated[int, Range(ge=0, le=MAX_PARTICLES)]  # hard cap of live particles
    seed: Annotated[int, Range(ge=0, lt=2**63)]  # seeds the random texture (numpy PCG64)
    # ETD2RK: stable at any dt/tau (a scene cannot know its dt: the master's clock sets it
    # per frame), exact where the exponential step is and second order elsewhere
    integrator: Integrator = Integrator.ETD2RK
    # edge of the square random texture
    random_texture_size: Annotated[int, Range.within(RANDOM_TEXTURE_SIZE_RANGE),
                                   Rule("a power of two", _power_of_two)] = 256
    engine: Engine = Engine.GS_TF  # how nodes step the particles (a run's --engine overrides)
    # "portable": every GPU computes the same bits, at a cost (README: portable arithmetic)
    arithmetic: Arithmetic = Arithmetic.NATIVE


@dataclass(frozen=True, kw_only=True)
class SceneFile:
    """The top level: its keys and what each holds. The loader reads it key by key (an
    emitter names its particle class, which becomes an index; [field] and [collision] have
    keys that depend on their kind)."""

    name: str | None = None  # default: the file's stem
    simulation: Simulation
    particle_class: tuple[ParticleClass, ...] = ()
    emitter: tuple[Emitter, ...] = ()
    forces: Forces = Forces()
    field: Field | None = None  # required exactly when forces.drag is set
    collision: Collision | None = None
    helicopter: Helicopter | None = None


@dataclass(frozen=True)
class UniformParams:
    velocity: Vec3


@dataclass(frozen=True)
class VortexParams:
    center: tuple[float, float]
    circulation: float
    core_radius: Annotated[float, Range(gt=0.0)]
    axial_speed: float = 0.0


@dataclass(frozen=True)
class DownwashParams:
    rotor_center: Vec3  # above ground_height
    rotor_radius: Annotated[float, Range(gt=0.0)]
    induced_velocity: Annotated[float, Range(ge=0.0)]
    ground_height: float = 0.0


@dataclass(frozen=True)
class NoParams:
    """The [field.params] of a kind that takes none (a file, the helicopter's rotor)."""


FIELD_PARAMS: dict[FieldKind, type] = {  # the [field.params] of each kind
    FieldKind.UNIFORM: UniformParams,
    FieldKind.VORTEX: VortexParams,
    FieldKind.DOWNWASH: DownwashParams,
    FieldKind.FILE: NoParams,
    FieldKind.ROTOR: NoParams,
}
