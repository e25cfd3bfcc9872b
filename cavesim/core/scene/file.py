"""The tables of a scene file that the engine never sees as such: the top level and the
[field.params] of each field kind.

`loader.parse_scene` reads a file through `SceneFile` and builds a `Scene` from it; the
other tables are the ones in `model.py` ([simulation] is the `Simulation` a `Scene` extends).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from cavesim.core._schema import Coordinate, Note, Range
from cavesim.core.features.collision import Collision
from cavesim.core.limits import MAX_FIELD_SNAPSHOTS
from cavesim.core.scene.model import (
    Emitter,
    Field,
    FieldKind,
    Forces,
    Helicopter,
    ParticleClass,
    Simulation,
    Vec3,
)


@dataclass(frozen=True, kw_only=True)
class SceneFile:
    """The top level: its keys and what each holds. The loader reads it key by key (an
    emitter names its particle class, which becomes an index; [field] and [collision] have
    keys that depend on their kind)."""

    name: str | None = None  # default: the file's stem
    base: Annotated[str, Note("a scene file (relative to this one) whose tables this one "
                              "extends: a key or table given here replaces the base's")
                    ] | None = None
    emission_scale: Annotated[float, Range(gt=0.0, le=1e6),
                              Note("every emitter's rate times this")] = 1.0
    simulation: Simulation
    particle_class: tuple[ParticleClass, ...] = ()
    emitter: tuple[Emitter, ...] = ()
    forces: Forces = Forces()
    field: Field | None = None  # required exactly when forces.drag is set
    collision: Collision | None = None
    helicopter: Helicopter | None = None


@dataclass(frozen=True)
class UniformParams:
    velocity: Vec3  # m/s


@dataclass(frozen=True)
class VortexParams:
    center: Annotated[tuple[float, float], Coordinate("xy")]  # [x, y] of the vertical axis, m
    circulation: float  # Γ, m²/s: > 0 turns counter-clockwise seen from above
    core_radius: Annotated[float, Range(gt=0.0)]  # m
    axial_speed: float = 0.0  # m/s, upward


@dataclass(frozen=True)
class DownwashParams:
    rotor_center: Annotated[Vec3, Coordinate()]  # m, above ground_height
    rotor_radius: Annotated[float, Range(gt=0.0)]  # m
    induced_velocity: Annotated[float, Range(ge=0.0)]  # m/s through the disk
    ground_height: Annotated[float, Coordinate("z")] = 0.0  # m


@dataclass(frozen=True)
class RotatingParams:
    """velocity turned about z by angular_speed × t, given as `snapshots` snapshots every
    `snapshot_interval` seconds from t = 0 (a test of interpolation in time)."""

    velocity: Vec3  # m/s at t = 0
    angular_speed: float  # rad/s, counter-clockwise seen from above
    snapshot_interval: Annotated[float, Range(gt=0.0, le=3600.0)]  # s
    snapshots: Annotated[int, Range(ge=2, le=MAX_FIELD_SNAPSHOTS)]  # stacked in one 3D texture

    def times(self) -> tuple[float, ...]:
        """The snapshot times: every snapshot_interval from 0."""
        return tuple(k * self.snapshot_interval for k in range(self.snapshots))


@dataclass(frozen=True)
class NoParams:
    """The [field.params] of a kind that takes none (a file, the helicopter's rotor)."""


FIELD_PARAMS: dict[FieldKind, type] = {  # the [field.params] of each kind
    FieldKind.UNIFORM: UniformParams,
    FieldKind.VORTEX: VortexParams,
    FieldKind.DOWNWASH: DownwashParams,
    FieldKind.FILE: NoParams,
    FieldKind.ROTOR: NoParams,
    FieldKind.ROTATING: RotatingParams,
}
