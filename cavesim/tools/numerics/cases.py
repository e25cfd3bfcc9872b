"""The flows the integrators are measured in, each a scene (built as a dict and checked by
the real loader), a fixed seeded particle set and the frame parameters of every step.

  uniform   uniform flow + gravity + Stokes drag: a closed-form solution exists
  vortex    a Lamb-Oseen vortex sampled from its trilinear grid, + gravity
  vortex_catmull_rom, vortex_bspline
            the same vortex grid interpolated C1 (Catmull-Rom) and C2 (cubic B-spline)
  downwash  the helicopter scene's rotor downwash under a fixed rotor frame, + gravity
  vortex_sand, downwash_sand
            the vortex and the downwash carrying the demo's sand, under Schiller-Naumann
            drag: the drag rate changes with the slip along each path
  rotating  a uniform flow turning at a steady rate, given as a time series of snapshots
            two steps apart and interpolated linearly in time: a closed form exists
  tracer    passive tracers (motion = "tracer") in a solid-body vortex on a grid, each
            method held to its tracer method's order: a closed form exists (a rotation)
  rotating_tracer
            passive tracers in the rotating case's time series: a closed form exists (an
            arc), and linear interpolation in time caps every method at order 2

Apart from the tracer cases, one particle class with tau = 0.1 s, so a run lasts T = 10 tau:
the particles forget how they started and follow the flow, the regime of the demo's cloud
(the sand: tau = 0.18 s, Re about 10). No emitters, no collision, nothing dies before T.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cavesim.core._toml import read_toml
from cavesim.core.errors import SceneError
from cavesim.core.fields.analytic import rotating_velocity
from cavesim.core.fields.grid import save_field
from cavesim.core.fields.snapshot_time import field_time_at
from cavesim.core.helicopter.rotor import induced_velocity
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import (
    AIR_VISCOSITY,
    Arithmetic,
    FieldInterpolation,
    FieldSampling,
    Integrator,
    Motion,
    Scene,
)
from cavesim.core.scene_frame import RotorFrame, SceneFrame
from cavesim.tools.numerics.solid_body import BOX, disk, solid_body, solid_body_grid

FINAL_TIME = 1.0  # s: a whole number of steps of every dt below
DTS = tuple(1.0 / (15 * 2**k) for k in range(7))  # 1/15 ... 1/960 s
QUICK_DTS = DTS[:5]  # 1/15 ... 1/240 s
REPORT_DT = 1.0 / 60  # the frame rate the table's error and cost columns are read at
PARTICLES, QUICK_PARTICLES = 20_000, 2_000
SEED = 2024
HELICOPTER_SCENE = "config/scenes/brownout.toml"  # the downwash case's default scene

TAU = 0.1  # s, Stokes relaxation time of the probe particles: T = 10 tau
DENSITY = 1000.0  # kg/m³
# tau = rho d² / (18 mu); Stokes drag named, as the closed-form references assume it
PROBE = {"name": "probe", "density": DENSITY, "drag": "stokes",
         "diameter": math.sqrt(18.0 * AIR_VISCOSITY * TAU / DENSITY)}
GRAVITY = [0.0, 0.0, -9.81]
LIFETIME = 1e9  # s: nobody dies
HUB_HEIGHT = 8.0  # m above the ground, for the downwash case
TRILINEAR_ORDER_LIMIT = 2  # see Case.order_limit
CATMULL_ROM_ORDER_LIMIT = 3  # C1: the second derivative jumps at the faces
BSPLINE_ORDER_LIMIT = 4  # C2: the third derivative jumps; no method here is above order 4
# The brownout's sand (config/scenes/brownout.toml), its drag law named: Schiller-Naumann's
# rate follows the slip, which no closed form follows
SAND = {"name": "sand", "density": 2650.0, "diameter": 150e-6, "drag": "schiller_naumann"}
# The methods a drag law whose rate depends on the slip is measured with: the exponential
# step holds the rate over the step (order 1), ETD2RK takes it at its second stage too
SAND_METHODS = (Integrator.EXPONENTIAL, Integrator.ETD2RK)
HELD_ORDER_TOLERANCE = 0.1
# The rotating case: 3 m/s turning at 2 rad/s, snapshots SNAPSHOT_STEPS steps apart. Linear
# interpolation in time errs by O(interval²), so every method of order 2 or more shows 2
ROTATION = 2.0  # rad/s
SNAPSHOT_STEPS = 2
TIME_INTERPOLATION_ORDER = 2
# one method of each kind: order 1, order 2 (the midpoint's and the exponential one's), and
# RK4 capped at 2 (each of its dts builds its own engine: a series per dt)
ROTATING_METHODS = (Integrator.EXPLICIT_EULER, Integrator.RK2, Integrator.RK4,
                    Integrator.ETD2RK)
# The tracer case: smoke in the solid-body vortex on a grid 1/8 m apart, whose node
# coordinates and values float32 holds exactly. The flow is linear, so trilinear
# interpolation is the flow itself and the float64 twin's error is the method's alone.
TRACER_NODES = 17
TRACER_PARTICLES = 500  # at most: a closed form per particle needs no more; keeps it cheap
SMOKE = {"name": "smoke", "diameter": 1e-5, "motion": Motion.TRACER.value}


@dataclass(frozen=True, eq=False)
class Case:
    name: str
    description: str
    data: dict[str, Any]  # the scene as the dict tomllib would give; integrator set per run
    particles: np.ndarray  # PARTICLE_DTYPE: the fixed start of every run
    frame: SceneFrame = SceneFrame()  # the scene's state (a rotor), the same every step
    # reference: the closed form of this name (reference.CLOSED_FORMS), else a fine
    # float64 RK4 run
    closed_form: str | None = None
    # a time series: its snapshots this many of the run's steps apart (each dt its own
    # scene); None: a steady field
    snapshot_steps: int | None = None
    # observed orders are held to the table (tests, report verdicts); False where the
    # errors reach their asymptotic order only below the quick run's dts
    held_to_order: bool = True
    # The highest order the field lets any method show. A trilinear grid is only Lipschitz:
    # its gradient jumps at every cell face, a step across a face errs by O(h²) (a quadrature
    # of a kinked integrand), and a path crosses a fixed number of faces, so the global error
    # is O(h²) whatever the method's order (RK4 on the analytic vortex shows 4). Likewise a
    # field that is C^k across the faces (a cubic interpolation) caps the order at k + 2.
    order_limit: int | None = None
    filtering: bool = False  # also run with hardware filtering and compare with manual
    cloud: bool = False  # also measure the concentration-field error (cloud.py)
    source: Path | None = None  # the scene file, for errors
    integrators: tuple[Integrator, ...] = tuple(Integrator)  # the methods run in the case
    order_tolerance: float | None = None  # on the observed order; None: each method's own
    # how the particles move: a tracer case's methods are their tracer methods (orders,
    # evaluations per step from Integrator.tracer_method)
    motion: Motion = Motion.INERTIAL

    def scene(self, integrator: Integrator, sampling: FieldSampling = FieldSampling.MANUAL,
              arithmetic: Arithmetic = Arithmetic.NATIVE, dt: float = REPORT_DT,
              final_time: float = FINAL_TIME) -> Scene:
        """The case's scene for a method (a time series: with its snapshots for steps of dt
        to final_time)."""
        data = copy.deepcopy(self.data)
        if self.snapshot_steps is not None:
            interval = self.snapshot_steps * dt
            data["field"]["params"].update(snapshot_interval=interval,
                                           snapshots=round(final_time / interval) + 2)
        data["simulation"]["integrator"] = integrator.value
        if arithmetic is not Arithmetic.NATIVE:
            data["simulation"]["arithmetic"] = arithmetic.value
        if sampling is not FieldSampling.MANUAL:
            data["field"]["sampling"] = sampling.value
        return parse_scene(data, self.source, self.name)

    def frame_at(self, scene: Scene, step: int, dt: float) -> SceneFrame:
        """The scene's state in step `step` of dt (from 0): the case's frame, and where a
        time series stands, as the master's clock puts it (`cavesim.core.drivers`)."""
        if scene.field.times is None:
            return self.frame
        h = float(np.float32(dt))  # the engine's step
        return dataclasses.replace(self.frame,
                                   field_time=field_time_at(scene.field.times, step * h, h))

    def subset(self, rows: slice) -> Case:
        """The same case with only the particles in `rows` (particles never interact)."""
        return dataclasses.replace(self, particles=self.particles[rows])


def _simulation(capacity: int) -> dict[str, Any]:
    return {"capacity": capacity, "seed": SEED, "integrator": Integrator.RK4.value,
            "random_texture_size": 64}


def _analytic_scene(field: dict[str, Any], capacity: int) -> dict[str, Any]:
    return {"simulation": _simulation(capacity), "particle_class": [dict(PROBE)],
            "forces": {"gravity": list(GRAVITY), "drag": {}}, "field": field}


def particle_set(positions: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Probe particles at `positions` (N, 3) with standard-normal velocities, never dying."""
    records = np.zeros(len(positions), dtype=PARTICLE_DTYPE)
    records["pos"] = positions
    records["vel"] = rng.normal(0.0, 1.0, size=(len(positions), 3))
    records["lifetime"] = LIFETIME
    return records


def _box_particles(count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return particle_set(rng.uniform((-3.0, -3.0, 0.5), (3.0, 3.0, 3.5), (count, 3)), rng)


def uniform_case(count: int) -> Case:
    # a constant is trilinear-interpolated exactly, and "clamp" keeps it constant outside
    field = {"kind": "uniform", "box_min": [-100.0, -100.0, -100.0],
             "box_max": [100.0, 100.0, 100.0], "resolution": [2, 2, 2], "out_of_domain": "clamp",
             "params": {"velocity": [3.0, -1.0, 0.5]}}
    return Case("uniform", "uniform flow (3, -1, 0.5) m/s + gravity + drag: closed form",
                _analytic_scene(field, count), _box_particles(count, SEED),
                closed_form="uniform")


def rotating_case(count: int) -> Case:
    """Uniform flow turning about z, snapshots SNAPSHOT_STEPS steps apart, linear between."""
    field = {"kind": "rotating", "box_min": [-100.0, -100.0, -100.0],
             "box_max": [100.0, 100.0, 100.0], "resolution": [2, 2, 2], "out_of_domain": "clamp",
             "params": {"velocity": [3.0, 0.0, 0.5], "angular_speed": ROTATION,
                        "snapshot_interval": SNAPSHOT_STEPS * REPORT_DT, "snapshots": 2}}
    return Case("rotating", f"uniform flow (3, 0, 0.5) m/s turning at {ROTATION:g} rad/s, "
                f"snapshots {SNAPSHOT_STEPS} steps apart, linear in time + gravity + drag: "
                "closed form", _analytic_scene(field, count), _box_particles(count, SEED + 3),
                closed_form="rotating", snapshot_steps=SNAPSHOT_STEPS,
                order_limit=TIME_INTERPOLATION_ORDER, order_tolerance=HELD_ORDER_TOLERANCE,
                integrators=ROTATING_METHODS)


def vortex_case(count: int) -> Case:
    # 0.5 m cells in x and y; the flow does not vary in z, so two nodes span z exactly
    field = {"kind": "vortex", "box_min": [-6.0, -6.0, -10.0], "box_max": [6.0, 6.0, 10.0],
             "resolution": [25, 25, 2], "out_of_domain": "clamp",
             "params": {"center": [0.3, -0.2], "circulation": 20.0, "core_radius": 1.0,
                        "axial_speed": 0.5}}
    return Case("vortex", "Lamb-Oseen vortex (circulation 20 m²/s, core 1 m) on a 25x25x2 "
                "grid + gravity + drag", _analytic_scene(field, count),
                _box_particles(count, SEED + 1), order_limit=TRILINEAR_ORDER_LIMIT,
                filtering=True)


def tracer_case(count: int, field_dir: Path) -> Case:
    """Tracers spread over a disk of radius 0.8 m in the solid-body vortex, its grid written
    to `field_dir` (kept for as long as the case is run)."""
    path = field_dir / "solid_body.npz"
    save_field(path, solid_body_grid(TRACER_NODES))
    field = {"kind": "file", "file": str(path), "box_min": list(BOX[0]),
             "box_max": list(BOX[1])}
    data = {"simulation": _simulation(count), "particle_class": [dict(SMOKE)],
            "forces": {"drag": {}}, "field": field}  # drag: what brings the flow in
    records = np.zeros(count, dtype=PARTICLE_DTYPE)
    records["pos"] = disk(count)
    records["vel"] = solid_body(records["pos"].astype(np.float64))  # a tracer's record
    records["lifetime"] = LIFETIME
    return Case("tracer", f"passive tracers in a solid-body vortex (1 rad/s) on a "
                f"{TRACER_NODES}³ grid, a disk of radius 0.8 m: closed form", data, records,
                closed_form="solid_body", motion=Motion.TRACER)


def rotating_tracer_case(count: int) -> Case:
    """Tracers in the rotating case's turning flow, a time series: each path is an arc and
    a climb in closed form, and linear interpolation in time caps every method at order 2."""
    rotating = rotating_case(count)
    data = copy.deepcopy(rotating.data)
    data["particle_class"] = [dict(SMOKE)]
    data["forces"] = {"drag": {}}  # what brings the flow in; no gravity acts on a tracer
    records = _box_particles(count, SEED + 5)
    records["vel"] = rotating_velocity(0.0, data["field"]["params"])  # a tracer's record
    return dataclasses.replace(
        rotating, name="rotating_tracer", data=data, particles=records,
        closed_form="rotating_tracer", motion=Motion.TRACER,
        description=f"passive tracers in a uniform flow (3, 0, 0.5) m/s turning at "
                    f"{ROTATION:g} rad/s, snapshots {SNAPSHOT_STEPS} steps apart, linear in "
                    "time: closed form")


def smooth_vortex_case(count: int, interpolation: FieldInterpolation, order_limit: int) -> Case:
    """The vortex case's grid and particles, interpolated by a cubic
    (cavesim.core.fields.interpolation) instead of trilinearly: RK4's observed order rises
    with the field's smoothness."""
    vortex = vortex_case(count)
    data = copy.deepcopy(vortex.data)
    data["field"]["interpolation"] = interpolation.value
    return dataclasses.replace(
        vortex, name=f"vortex_{interpolation.value}", data=data, order_limit=order_limit,
        description=f"{vortex.description}; the grid interpolated {interpolation.value}",
        filtering=False)


def downwash_case(helicopter_scene: Path, count: int) -> Case:
    """The scene file's rotor downwash (its helicopter, forces and field), without its
    emitters, ground and random walk (deterministic paths to measure), under a fixed rotor
    HUB_HEIGHT above the ground at full speed."""
    data = read_toml(helicopter_scene, SceneError, "scene file")
    if "helicopter" not in data or data.get("field", {}).get("kind") != "rotor":
        raise SceneError(f"{helicopter_scene}: the downwash case needs a helicopter scene with "
                         f"field.kind = 'rotor', got helicopter "
                         f"{'present' if 'helicopter' in data else 'missing'} and field.kind = "
                         f"{data.get('field', {}).get('kind')!r}")
    data = {key: value for key, value in data.items() if key not in ("emitter", "collision")}
    data["forces"] = {key: value for key, value in data["forces"].items()
                      if key != "dispersion"}
    data["simulation"] = _simulation(count)
    data["particle_class"] = [dict(PROBE)]
    scene = parse_scene(data, helicopter_scene)
    helicopter = scene.helicopter
    rotor = RotorFrame(hub=(0.0, 0.0, HUB_HEIGHT),
                       induced_velocity=induced_velocity(helicopter, 1.0, HUB_HEIGHT),
                       rotor_speed=1.0, emission_factors=())
    # the wake and the wall jet: 0.5 R to 2.5 R from the rotor axis, 1 m to 6 m up
    rng = np.random.default_rng(SEED + 2)
    radius = helicopter.rotor_radius * rng.uniform(0.5, 2.5, count)
    angle = rng.uniform(0.0, 2 * np.pi, count)
    positions = np.stack([radius * np.cos(angle), radius * np.sin(angle),
                          rng.uniform(1.0, 6.0, count)], axis=1)
    return Case("downwash", f"rotor downwash of {scene.name} (hub {HUB_HEIGHT:g} m up, "
                f"v_i {rotor.induced_velocity:.2f} m/s) + gravity + drag; no ground",
                data, particle_set(positions, rng), SceneFrame(rotor=rotor), held_to_order=False,
                cloud=True, source=helicopter_scene)


def sand_case(case: Case) -> Case:
    """`case`'s flow and particles, carrying sand under Schiller-Naumann drag, measured with
    SAND_METHODS and held to their orders within HELD_ORDER_TOLERANCE."""
    data = copy.deepcopy(case.data)
    data["particle_class"] = [dict(SAND)]
    return dataclasses.replace(
        case, name=f"{case.name}_sand", data=data, held_to_order=True, filtering=False,
        cloud=False, integrators=SAND_METHODS, order_tolerance=HELD_ORDER_TOLERANCE,
        description=f"{case.description}; 150 µm sand, Schiller-Naumann drag")


def build_cases(helicopter_scene: Path, count: int, field_dir: Path) -> list[Case]:
    """The ten cases with `count` particles each (the tracer cases: at most
    TRACER_PARTICLES), writing grid files to `field_dir`."""
    downwash = downwash_case(helicopter_scene, count)
    return [uniform_case(count), rotating_case(count), vortex_case(count),
            smooth_vortex_case(count, FieldInterpolation.CATMULL_ROM, CATMULL_ROM_ORDER_LIMIT),
            smooth_vortex_case(count, FieldInterpolation.BSPLINE, BSPLINE_ORDER_LIMIT),
            downwash, sand_case(vortex_case(count)), sand_case(downwash),
            tracer_case(min(count, TRACER_PARTICLES), field_dir),
            rotating_tracer_case(min(count, TRACER_PARTICLES))]
