"""Typed scene objects: what one simulated world holds, as loaded from `config/scenes/*.toml`.

Coordinates are room metres with z up; times are seconds. Every object is frozen so a
scene can be shared between the GL engine and its numpy twin without either changing it.
Most of them are also the tables of a scene file: each field is a key, with its bounds beside
it (`cavesim.core._schema` reads them); `file.py` holds the tables only the file has.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Annotated

from cavesim.core._schema import Coordinate, Range, Rule
from cavesim.core.air import AIR_VISCOSITY
from cavesim.core.features.collision import Collision
from cavesim.core.features.dispersion import Dispersion
from cavesim.core.features.stokes_drag import Drag
from cavesim.core.limits import (
    FIELD_RESOLUTION_RANGE,
    MAX_DIAMETER,
    MAX_FIELD_NODES,
    MAX_LAUNCH_SPEED,
    MAX_LIFETIME,
    MAX_PARTICLES,
    MAX_RATE,
    RANDOM_TEXTURE_SIZE_RANGE,
)

Vec3 = tuple[float, float, float]



class TracerMethod(StrEnum):
    """How a passive tracer, dx/dt = u(x, t), is stepped: an explicit Runge-Kutta method, one
    row each. Its code is `trace`'s branch in shaders/include/tracers.glsl and a step of the
    row's name in cavesim/core/twin/tracers.py and cavesim/core/portable/tracers.py."""

    gpu_id: int  # the particle pass's id TRACER_<NAME>: the TRACER_METHOD define's value
    order: int  # theoretical order of accuracy (an adaptive method's at a fixed substep)
    # flow samples per particle and step (an adaptive method's per substep tried), besides
    # the one at the new position that gives the record its velocity
    field_evaluations: int

    def __new__(cls, name: str, gpu_id: int, order: int, field_evaluations: int
                ) -> TracerMethod:
        member = str.__new__(cls, name)
        member._value_ = name
        member.gpu_id = gpu_id
        member.order = order
        member.field_evaluations = field_evaluations
        return member

    # (name, GPU id, order, field evaluations)
    EULER = "euler", 0, 1, 1
    MIDPOINT = "midpoint", 1, 2, 2
    HEUN = "heun", 2, 2, 2  # the explicit trapezoid rule
    RK4 = "rk4", 3, 4, 4
    RK45 = "rk45", 4, 5, 6  # Dormand-Prince 5(4) in substeps held to tracer_tolerance


class Integrator(StrEnum):
    """The integrators, one row each: everything a new one adds besides its code.

    Its code is `integrate`'s branch in shaders/include/integrators.glsl and a step function of
    the row's name in cavesim/core/twin/integrators.py and cavesim/core/portable/integrators.py.
    """

    gpu_id: int  # the particle pass's id INTEGRATOR_<NAME>: the INTEGRATOR define's value
    order: int  # theoretical order of accuracy
    field_evaluations: int  # flow samples per particle and step (a test counts the twin's)
    stability_limit: float  # the largest dt/tau at which linear drag stays bounded
    tracer_method: TracerMethod  # what the method becomes without inertia (a tracer class)

    def __new__(cls, name: str, gpu_id: int, order: int, field_evaluations: int,
                stability_limit: float, tracer_method: str) -> Integrator:
        member = str.__new__(cls, name)
        member._value_ = name
        member.gpu_id = gpu_id
        member.order = order
        member.field_evaluations = field_evaluations
        member.stability_limit = stability_limit
        member.tracer_method = TracerMethod(tracer_method)
        return member

    # (name in a scene file, GPU id, order, field evaluations, stability limit, tracer
    # method). The tracer method is the integrator without inertia: semi-implicit and
    # exponential Euler, without drag, are Euler's; trapezoid and Verlet take the mean of the
    # velocity (acceleration) at the step's ends, which for a tracer is Heun's; ETD2RK with
    # lambda = 0 is Heun's too (Cox & Matthews 2002).
    EXPLICIT_EULER = "explicit_euler", 0, 1, 1, 2.0, "euler"
    SEMI_IMPLICIT_EULER = "semi_implicit_euler", 1, 1, 1, math.inf, "euler"  # implicit in the drag
    TRAPEZOID = "trapezoid", 2, 1, 1, 2.0, "heun"  # its velocity is Euler's
    VERLET = "verlet", 3, 2, 2, 2.0, "heun"
    RK2 = "rk2", 4, 2, 2, 2.0, "midpoint"
    RK4 = "rk4", 5, 4, 4, 2.785, "rk4"
    EXPONENTIAL = "exponential", 6, 1, 1, math.inf, "euler"  # the drag is solved exactly
    # evaluated at the start and at the exponential step's predicted position
    ETD2RK = "etd2rk", 7, 2, 2, math.inf, "heun"


class Engine(StrEnum):
    """How a node steps the particle stream; both paths give the same bytes on one driver."""

    GS_TF = "gs_tf"  # geometry shader + transform feedback: the paper's method, the reference
    COMPUTE = "compute"  # compute shaders: in-place update, ordered compaction, append
    AUTO = "auto"  # the faster path on the node's context, by a timed probe at start-up;
    # the master has every node of a run step with one (nodes/master/engine_choice.py)


ENGINE_PATHS = (Engine.GS_TF, Engine.COMPUTE)  # the paths a system steps with (not AUTO)


class Arithmetic(StrEnum):
    """How the particle and emission arithmetic is compiled (docs/numerics.md: portable
    arithmetic)."""

    NATIVE = "native"  # the driver's operators and built-ins: fastest, bits vary by GPU
    PORTABLE = "portable"  # correctly rounded +, -, * only: the same bits on every GPU


class OutOfDomain(StrEnum):
    CLAMP = "clamp"  # the flow at the nearest boundary node
    ZERO = "zero"  # still air outside the box


class FieldSampling(StrEnum):
    MANUAL = "manual"  # trilinear from texelFetch in float32: the same on every GPU
    HARDWARE = "hardware"  # the texture unit's filtering: faster, vendor-dependent weights


class FieldInterpolation(StrEnum):
    """How a gridded flow is interpolated between its nodes
    (cavesim/core/fields/interpolation.py)."""

    TRILINEAR = "trilinear"  # C0, error O(h²): 8 texels; caps RK4 at order 2
    CATMULL_ROM = "catmull_rom"  # C1, error O(h³): 64 texels; caps RK4 at order 3
    BSPLINE = "bspline"  # C2, error O(h⁴), prefiltered cubic B-spline: 64 texels; RK4 keeps 4


class FieldKind(StrEnum):
    UNIFORM = "uniform"  # one velocity everywhere
    VORTEX = "vortex"  # a Lamb-Oseen vortex about a vertical axis
    DOWNWASH = "downwash"  # a fixed rotor's downwash and its ground outwash
    FILE = "file"  # a grid from a .npz, .nc (NetCDF) or .vti (VTK) file
    ROTOR = "rotor"  # the scene's helicopter's downwash, evaluated on the GPU each frame
    ROTATING = "rotating"  # a uniform flow turning about z, as a time series of snapshots


class DragLaw(StrEnum):
    """How drag grows with the particle Reynolds number Re = |u - v| d / nu (cavesim.core.drag)."""

    STOKES = "stokes"  # C_D = 24/Re: linear in the slip, for Re well below 1
    SCHILLER_NAUMANN = "schiller_naumann"  # C_D = 24/Re (1 + 0.15 Re^0.687), Re up to 800


class Motion(StrEnum):
    """How a particle class moves (docs/numerics.md: passive tracers)."""

    INERTIAL = "inertial"  # dv/dt = (u - v) lambda + g - k v: drag toward the flow
    TRACER = "tracer"  # dx/dt = u(x, t): carried by the flow, no inertia, gravity or damping


@dataclass(frozen=True)
class ParticleClass:
    name: str
    # m; a tracer's only sizes it where it is drawn
    diameter: Annotated[float, Range(gt=0.0, le=MAX_DIAMETER)]
    # kg/m³: required for an inertial class, not allowed for a tracer (it has no inertia)
    density: Annotated[float, Range(gt=0.0)] | None = None
    # None: the loader decides by the particle Reynolds number at the scene's speeds
    # (cavesim.core.drag.chosen_law); a scene may name the law it wants. Not allowed for a
    # tracer, on which no drag acts.
    drag: DragLaw | None = None
    # "tracer" needs forces.drag (which brings the flow in) and no forces.dispersion
    motion: Motion = Motion.INERTIAL

    def relaxation_time(self, air_viscosity: float = AIR_VISCOSITY) -> float:
        """Stokes relaxation time τ = ρ d² / (18 μ) in seconds; 0 for a tracer."""
        if self.motion is Motion.TRACER:
            return 0.0
        return self.density * self.diameter**2 / (18.0 * air_viscosity)


# Rules beside a field are named functions: an annotation's lambda would not see this module.
def _usable_direction(v: Vec3) -> bool:
    return 0.0 < math.hypot(*v) < math.inf


def _ordered(pair: tuple[float, float]) -> bool:
    return pair[0] <= pair[1]


def _few_field_nodes(resolution: tuple[int, int, int]) -> bool:
    return math.prod(resolution) <= MAX_FIELD_NODES


def _power_of_two(n: int) -> bool:
    return n & (n - 1) == 0


MODEL_SUFFIXES = (".glb", ".gltf")  # glTF 2.0, binary or JSON


def _gltf_suffix(path: Path) -> bool:
    return path.suffix.lower() in MODEL_SUFFIXES


@dataclass(frozen=True, kw_only=True)
class Emitter:
    name: str
    position: Annotated[Vec3, Coordinate()]  # centre of the emission box
    # full edge lengths of the emission box (0 = a point along that axis)
    extent: Annotated[Vec3, Range(ge=0.0)] = (0.0, 0.0, 0.0)
    rate: Annotated[float, Range(ge=0.0, le=MAX_RATE)]  # particles per second
    speed: Annotated[float, Range(ge=0.0, le=MAX_LAUNCH_SPEED)] = 0.0  # mean initial speed, m/s
    # initial speed is uniform in [speed - spread, speed + spread]: spread <= speed
    speed_spread: Annotated[float, Range(ge=0.0)] = 0.0
    # unit vector of the mean initial velocity (the loader normalizes the file's vector)
    direction: Annotated[Vec3, Rule("with a non-zero, finite length", _usable_direction)] = (
        0.0, 0.0, 1.0)
    spread_angle: Annotated[float, Range(ge=0.0, le=180.0)] = 0.0  # cone half-angle, degrees
    # uniform range [min, max] in seconds
    lifetime: Annotated[tuple[float, float], Range(gt=0.0, le=MAX_LIFETIME),
                        Rule("[min, max] with min <= max", _ordered)]
    particle_class: int  # index into Scene.particle_classes (the file gives its name)
    follow_helicopter: bool = False  # position is relative to the point below the rotor hub;
    # rate is scaled each frame by the ground's saltation under the downwash


@dataclass(frozen=True)
class Forces:
    gravity: Vec3 | None = None  # None: no gravity compiled in
    drag: Drag | None = None  # None: no Stokes drag, and no field texture
    # linear damping rate k in a = -k v, 1/s
    damping: Annotated[float, Range(gt=0.0)] | None = None
    dispersion: Dispersion | None = None  # None: no turbulent random walk compiled in
    # Omega, rad/s: the rotation of the frame the scene is in (a = -2 Omega x v; the Earth's
    # 7.2921e-5 about its axis, of which Omega sin(latitude) is the local vertical)
    coriolis: Vec3 | None = None


@dataclass(frozen=True)
class Field:
    kind: FieldKind
    box_min: Annotated[Vec3, Coordinate()]
    box_max: Annotated[Vec3, Coordinate()]  # > box_min on every axis
    # grid nodes per axis (from the file for FILE)
    resolution: Annotated[tuple[int, int, int], Range.within(FIELD_RESOLUTION_RANGE),
                          Rule(f"at most {MAX_FIELD_NODES} nodes in all", _few_field_nodes)]
    out_of_domain: OutOfDomain = OutOfDomain.CLAMP
    sampling: FieldSampling = FieldSampling.MANUAL
    interpolation: FieldInterpolation = FieldInterpolation.TRILINEAR
    params: dict[str, object] = field(default_factory=dict)  # file.FIELD_PARAMS[kind] as a dict
    # for FILE: .npz with array "velocity" (nz, ny, nx, 3); .nc (NetCDF, CF conventions)
    # or .vti (VTK XML ImageData), whose coordinates give the box (cavesim.core.fields.flow_files)
    file: Path | None = None
    # .nc: the x, y and z velocity variables (default: by CF standard_name, else u, v, w)
    variables: tuple[str, str, str] | None = None
    vector: str | None = None  # .vti: its 3-component point array (default: its Vectors)
    velocity_units: str | None = None  # .nc, .vti: overrides the file's (default m/s)
    length_units: str | None = None  # .nc, .vti: of the coordinates (default metres)
    time_units: str | None = None  # .nc: of the time coordinate (default: its units attribute)
    # A time series' snapshot times, s from the first (the file's, or ROTATING's params);
    # None: a steady field. Not a key of the scene file: the loader fills it in.
    times: tuple[float, ...] | None = None

    @property
    def named_variables(self) -> tuple[str, ...] | None:
        """What the file is read for (`cavesim.core.fields.flow_files.read_flow_file`): a .nc's
        three velocity variables or a .vti's vector array, if the scene names them."""
        return self.variables if self.vector is None else (self.vector,)


@dataclass(frozen=True)
class WandKey:
    """One key of a scripted wand timeline: where the wand is and how far it is tilted."""

    t: Annotated[float, Range(ge=0.0)]  # s from the start; keys in order
    position: Vec3  # room metres
    # degrees; 0 = level = hover rotor speed, + faster, - slower
    tilt: Annotated[float, Range(ge=-90.0, le=90.0)] = 0.0


@dataclass(frozen=True)
class Helicopter:
    mass: Annotated[float, Range(gt=0.0, le=1e6)]  # kg
    rotor_radius: Annotated[float, Range(gt=0.0, le=100.0)]  # m
    hub_height: Annotated[float, Range(gt=0.0, le=50.0)]  # m from the skids up to the rotor hub
    air_density: Annotated[float, Range(gt=0.0, le=10.0)] = 1.225  # kg/m³
    # main rotor turns per second at hover speed
    rotor_hz: Annotated[float, Range(gt=0.0, le=100.0)] = 4.5
    # m/s: no saltation below
    threshold_friction_velocity: Annotated[float, Range(gt=0.0)] = 0.25
    # m, of the ground, for the friction velocity
    roughness_length: Annotated[float, Range(gt=0.0, le=1.0)] = 1e-3
    # world position of the room origin (for steering)
    wand_origin: Annotated[Vec3, Coordinate()] = (0.0, 0.0, 0.0)
    # world metres per room metre of wand motion
    wand_scale: Annotated[float, Range(gt=0.0, le=1e4)] = 10.0
    # s: the helicopter follows the wand with this lag
    response_time: Annotated[float, Range(gt=0.0, le=60.0)] = 1.0
    timeline: tuple[WandKey, ...] = ()  # scripted wand for headless runs
    # what the walls draw (not set: the built-in body, config/models/utility_helicopter.glb):
    # a file relative to the scene file, in glTF's axes (Y up, +Z forward, +X left) and
    # metres, its origin on the ground between the skids and the rotor hub 1.3 m up
    # (scene_frame.MESH_HUB_HEIGHT; the pose scales it by hub_height / 1.3); triangles only;
    # colours are the materials' baseColorFactor (textures are ignored); a node "tail_rotor"
    # is not drawn but places the tail rotor: its origin the hub, its largest scale the
    # radius (cavesim/gpu/render/gltf_model.py)
    model: Annotated[Path, Rule(f"a glTF file: {' or '.join(MODEL_SUFFIXES)}",
                                _gltf_suffix)] | None = None

    @property
    def disk_area(self) -> float:
        return math.pi * self.rotor_radius**2

    @property
    def weight(self) -> float:
        return self.mass * 9.81


@dataclass(frozen=True)
class Simulation:
    """[simulation]: how the world is run; a `Scene` is these settings and the world."""

    capacity: Annotated[int, Range(ge=0, le=MAX_PARTICLES)]  # hard cap of live particles
    seed: Annotated[int, Range(ge=0, lt=2**63)]  # seeds the random texture (numpy PCG64)
    # ETD2RK: stable at any dt/tau (a scene cannot know its dt: the master's clock sets it
    # per frame), exact where the exponential step is and second order elsewhere
    integrator: Integrator = Integrator.ETD2RK
    # edge of the square random texture
    random_texture_size: Annotated[int, Range.within(RANDOM_TEXTURE_SIZE_RANGE),
                                   Rule("a power of two", _power_of_two)] = 256
    engine: Engine = Engine.GS_TF  # how nodes step the particles (a run's --engine overrides)
    # "portable": every GPU computes the same bits, at a cost (docs/numerics.md)
    arithmetic: Arithmetic = Arithmetic.NATIVE
    # world position of the scene's own origin, positions kept relative to it (None: the
    # world's; cavesim.core.scene.origin): a scene kilometres out keeps the floor of one at 0
    origin: Vec3 | None = None
    # how tracer classes step (not set: the integrator's form without inertia, its row's
    # tracer_method); "rk45" divides each frame into substeps held to tracer_tolerance
    tracer_method: TracerMethod | None = None
    # m: the largest error a substep of "rk45" may estimate (its largest component)
    tracer_tolerance: Annotated[float, Range(ge=1e-10, le=1.0)] = 1e-6


@dataclass(frozen=True, kw_only=True)
class Scene(Simulation):
    """One simulated world: its [simulation] settings and everything it holds."""

    name: str
    source: Path | None  # the TOML file it came from, for error messages
    particle_classes: tuple[ParticleClass, ...]
    emitters: tuple[Emitter, ...]
    forces: Forces
    field: Field | None  # required exactly when forces.drag is set
    collision: Collision | None
    helicopter: Helicopter | None = None

    @property
    def gridded_flow(self) -> bool:
        """Whether drag carries the particles toward a gridded field (one with a box to
        leave), not the rotor's analytic downwash."""
        return self.forces.drag is not None and self.field.kind is not FieldKind.ROTOR

    def relaxation_times(self) -> tuple[float, ...]:
        """τ of each particle class (inf when the scene has no drag)."""
        if self.forces.drag is None:
            return tuple(math.inf for _ in self.particle_classes)
        mu = self.forces.drag.air_viscosity
        return tuple(c.relaxation_time(mu) for c in self.particle_classes)

    def inverse_relaxation_times(self) -> tuple[float, ...]:
        """1/τ of each particle class: 0 without drag and for a tracer, on which drag never
        acts (the particle pass steps it by its own method)."""
        return tuple(0.0 if c.motion is Motion.TRACER else 1.0 / tau
                     for c, tau in zip(self.particle_classes, self.relaxation_times(),
                                       strict=True))

    @property
    def method_for_tracers(self) -> TracerMethod:
        """How the tracer classes step: the scene's tracer_method, else the integrator's."""
        return self.tracer_method or self.integrator.tracer_method

    @property
    def tracers_take_substeps(self) -> bool:
        """Whether the scene has tracers and steps them in substeps (TracerMethod.RK45)."""
        return any(self.tracer_classes) and self.method_for_tracers is TracerMethod.RK45

    @property
    def tracer_classes(self) -> tuple[bool, ...]:
        """Whether each particle class is a passive tracer."""
        return tuple(c.motion is Motion.TRACER for c in self.particle_classes)

    def reynolds_per_speed(self) -> tuple[float, ...]:
        """d / nu of each Schiller-Naumann class (Re = this × |u - v|), 0 for Stokes ones."""
        if self.forces.drag is None:
            return tuple(0.0 for _ in self.particle_classes)
        nu = self.forces.drag.kinematic_viscosity
        return tuple(c.diameter / nu if c.drag is DragLaw.SCHILLER_NAUMANN else 0.0
                     for c in self.particle_classes)
