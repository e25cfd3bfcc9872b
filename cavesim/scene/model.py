"""Typed scene objects: what one simulated world holds, as loaded from `config/scenes/*.toml`.

Coordinates are room metres with z up; times are seconds. Every object is frozen so a
scene can be shared between the GL engine and its numpy twin without either changing it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

Vec3 = tuple[float, float, float]

AIR_VISCOSITY = 1.81e-5  # Pa·s, dry air at 15 °C


class Integrator(StrEnum):
    EXPLICIT_EULER = "explicit_euler"
    SEMI_IMPLICIT_EULER = "semi_implicit_euler"
    TRAPEZOID = "trapezoid"
    VERLET = "verlet"
    RK2 = "rk2"
    RK4 = "rk4"
    EXPONENTIAL = "exponential"


class OutOfDomain(StrEnum):
    CLAMP = "clamp"  # the flow at the nearest boundary node
    ZERO = "zero"  # still air outside the box


class FieldSampling(StrEnum):
    MANUAL = "manual"  # trilinear from texelFetch in float32: the same on every GPU
    HARDWARE = "hardware"  # the texture unit's filtering: faster, vendor-dependent weights


class FieldKind(StrEnum):
    UNIFORM = "uniform"
    VORTEX = "vortex"
    DOWNWASH = "downwash"
    FILE = "file"
    ROTOR = "rotor"  # the scene's helicopter's downwash, evaluated on the GPU each frame


class CollisionKind(StrEnum):
    PLANE = "plane"
    HEIGHTFIELD = "heightfield"


@dataclass(frozen=True)
class ParticleClass:
    name: str
    diameter: float  # m
    density: float  # kg/m³

    def relaxation_time(self, air_viscosity: float = AIR_VISCOSITY) -> float:
        """Stokes relaxation time τ = ρ d² / (18 μ) in seconds."""
        return self.density * self.diameter**2 / (18.0 * air_viscosity)


@dataclass(frozen=True)
class Emitter:
    name: str
    position: Vec3  # centre of the emission box
    extent: Vec3  # full edge lengths of the emission box (0 = a point along that axis)
    rate: float  # particles per second, >= 0
    speed: float  # mean initial speed, m/s
    speed_spread: float  # initial speed is uniform in [speed - spread, speed + spread]
    direction: Vec3  # unit vector of the mean initial velocity
    spread_angle: float  # half-angle of the emission cone, degrees in [0, 180]
    lifetime: tuple[float, float]  # uniform range [min, max] in seconds, 0 < min <= max
    particle_class: int  # index into Scene.particle_classes
    follow_helicopter: bool = False  # position is relative to the point below the rotor hub;
    # rate is scaled each frame by the ground's saltation under the downwash


@dataclass(frozen=True)
class Drag:
    air_viscosity: float = AIR_VISCOSITY


@dataclass(frozen=True)
class Forces:
    gravity: Vec3 | None = None  # None: no gravity compiled in
    drag: Drag | None = None  # None: no Stokes drag, and no field texture
    damping: float | None = None  # linear damping rate k in a = -k v, 1/s


@dataclass(frozen=True)
class Field:
    kind: FieldKind
    box_min: Vec3
    box_max: Vec3
    resolution: tuple[int, int, int]  # grid nodes per axis, each >= 2 (from the file for FILE)
    out_of_domain: OutOfDomain = OutOfDomain.CLAMP
    sampling: FieldSampling = FieldSampling.MANUAL
    params: dict[str, object] = field(default_factory=dict)  # kind-specific, validated
    file: Path | None = None  # for FILE: .npz with array "velocity" (nz, ny, nx, 3)


@dataclass(frozen=True)
class Collision:
    kind: CollisionKind
    friction: float  # ν in [0, 1]: share of tangential speed lost at a bounce
    resilience: float  # ε in [0, 1]: share of normal speed kept at a bounce
    friction_min_speed: float = 0.0  # m/s: below this speed no friction is applied
    height: float = 0.0  # PLANE: ground height z
    file: Path | None = None  # HEIGHTFIELD: .npz with "height" (nx, ny), "box_min", "box_max"


@dataclass(frozen=True)
class WandKey:
    """One key of a scripted wand timeline: where the wand is and how far it is tilted."""

    t: float  # s from the start
    position: Vec3  # room metres
    tilt: float  # degrees; 0 = level = hover rotor speed, + faster, - slower


@dataclass(frozen=True)
class Helicopter:
    mass: float  # kg
    rotor_radius: float  # m
    hub_height: float  # m from the skids up to the rotor hub
    air_density: float = 1.225  # kg/m³
    rotor_hz: float = 4.5  # main rotor turns per second at hover speed
    threshold_friction_velocity: float = 0.25  # m/s: no saltation below
    roughness_length: float = 1e-3  # m, of the ground, for the friction velocity
    wand_origin: Vec3 = (0.0, 0.0, 0.0)  # world position of the room origin (for steering)
    wand_scale: float = 10.0  # world metres per room metre of wand motion
    response_time: float = 1.0  # s: the helicopter follows the wand with this lag
    timeline: tuple[WandKey, ...] = ()  # scripted wand for headless runs

    @property
    def disk_area(self) -> float:
        return math.pi * self.rotor_radius**2

    @property
    def weight(self) -> float:
        return self.mass * 9.81


@dataclass(frozen=True)
class Scene:
    name: str
    source: Path | None  # the TOML file it came from, for error messages
    capacity: int  # hard cap of live particles
    seed: int  # seeds the random texture (numpy PCG64)
    integrator: Integrator
    random_texture_size: int  # edge of the square random texture, a power of two
    particle_classes: tuple[ParticleClass, ...]
    emitters: tuple[Emitter, ...]
    forces: Forces
    field: Field | None  # required exactly when forces.drag is set
    collision: Collision | None
    helicopter: Helicopter | None = None

    def relaxation_times(self) -> tuple[float, ...]:
        """τ of each particle class (inf when the scene has no drag)."""
        if self.forces.drag is None:
            return tuple(math.inf for _ in self.particle_classes)
        mu = self.forces.drag.air_viscosity
        return tuple(c.relaxation_time(mu) for c in self.particle_classes)
