"""One parser per table of a scene file: a checked `Table` in, a frozen model object out.

`loader.parse_scene` calls these in file order; cross-table rules (emitter → particle class,
drag ⇔ field) are checked there, where both sides are known.
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from numpy.lib import format as npy_format

from cavesim.limits import (
    FIELD_RESOLUTION_RANGE,
    MAX_DIAMETER,
    MAX_FIELD_NODES,
    MAX_LIFETIME,
    MAX_PARTICLES,
    MAX_RATE,
    RANDOM_TEXTURE_SIZE_RANGE,
)
from cavesim.scene._checks import Table
from cavesim.scene.model import (
    AIR_VISCOSITY,
    Collision,
    CollisionKind,
    Drag,
    Emitter,
    Field,
    FieldKind,
    FieldSampling,
    Forces,
    Helicopter,
    Integrator,
    OutOfDomain,
    ParticleClass,
    WandKey,
)

SIMULATION_KEYS = ("capacity", "seed", "integrator", "random_texture_size")
PARTICLE_CLASS_KEYS = ("name", "diameter", "density")
EMITTER_KEYS = ("name", "position", "extent", "rate", "speed", "speed_spread", "direction",
                "spread_angle", "lifetime", "particle_class", "follow_helicopter")
HELICOPTER_KEYS = ("mass", "rotor_radius", "hub_height", "air_density", "rotor_hz",
                   "threshold_friction_velocity", "roughness_length", "wand_origin",
                   "wand_scale", "response_time", "timeline")
WAND_KEY_KEYS = ("t", "position", "tilt")
FORCES_KEYS = ("gravity", "damping", "drag")
FIELD_KEYS = ("kind", "box_min", "box_max", "resolution", "out_of_domain", "sampling", "file",
              "params")
COLLISION_KEYS = ("kind", "friction", "resilience", "friction_min_speed", "height", "file")


def simulation(t: Table) -> dict[str, Any]:
    """The [simulation] table as keyword arguments of `Scene`."""
    low, high = RANDOM_TEXTURE_SIZE_RANGE
    size = t.integer("random_texture_size", 256, ge=low, le=high)
    if size & (size - 1):
        raise t.fail("random_texture_size", f"must be a power of two >= {low} and <= {high}")
    return {
        "capacity": t.integer("capacity", ge=0, le=MAX_PARTICLES),
        "seed": t.integer("seed", ge=0, lt=2**63),
        "integrator": t.choice("integrator", Integrator, Integrator.EXPONENTIAL),
        "random_texture_size": size,
    }


def particle_class(t: Table) -> ParticleClass:
    return ParticleClass(
        name=t.string("name"),
        diameter=t.number("diameter", gt=0.0, le=MAX_DIAMETER),
        density=t.number("density", gt=0.0),
    )


def emitter(t: Table, class_index: Mapping[str, int]) -> Emitter:
    """An [[emitter]]; `class_index` maps particle class names to their index."""
    name = t.string("name")
    position = t.floats("position", 3)
    speed = t.number("speed", 0.0, ge=0.0)
    spread = t.number("speed_spread", 0.0, ge=0.0)
    if spread > speed:  # the speed drawn from [speed - spread, speed + spread] must be >= 0
        raise t.fail("speed_spread", f"must be a finite number >= 0 and <= {t.sub('speed')} "
                                     f"= {speed!r}")
    direction = t.floats("direction", 3, (0.0, 0.0, 1.0))
    norm = math.hypot(*direction)
    if norm == 0.0 or not math.isfinite(norm):
        raise t.fail("direction", "must be a list of 3 finite numbers of non-zero length")
    lifetime = t.floats("lifetime", 2)
    if not 0.0 < lifetime[0] <= lifetime[1] <= MAX_LIFETIME:
        raise t.fail("lifetime", f"must be [min, max] with 0 < min <= max <= {MAX_LIFETIME:g}")
    cls = t.string("particle_class")
    if cls not in class_index:
        names = ", ".join(repr(n) for n in class_index) or "none are defined"
        raise t.fail("particle_class", f"must name a [[particle_class]]: {names}")
    return Emitter(
        name=name,
        position=position,
        extent=t.floats("extent", 3, (0.0, 0.0, 0.0), ge=0.0),
        rate=t.number("rate", ge=0.0, le=MAX_RATE),
        speed=speed,
        speed_spread=spread,
        direction=tuple(x / norm for x in direction),  # type: ignore[arg-type]
        spread_angle=t.number("spread_angle", 0.0, ge=0.0, le=180.0),
        lifetime=lifetime,
        particle_class=class_index[cls],
        follow_helicopter=t.boolean("follow_helicopter", False),
    )


def helicopter(t: Table) -> Helicopter:
    """The [helicopter] table and its scripted wand [[helicopter.timeline]]."""
    keys = []
    for i, raw in enumerate(t.tables("timeline")):
        k = Table(t.src, f"{t.sub('timeline')}[{i}]", raw, WAND_KEY_KEYS)
        key = WandKey(k.number("t", ge=0.0), k.floats("position", 3),
                      k.number("tilt", 0.0, ge=-90.0, le=90.0))
        if keys and key.t <= keys[-1].t:
            raise k.fail("t", f"must be > the previous key's t = {keys[-1].t!r}: keys in order")
        keys.append(key)
    return Helicopter(
        mass=t.number("mass", gt=0.0, le=1e6),
        rotor_radius=t.number("rotor_radius", gt=0.0, le=100.0),
        hub_height=t.number("hub_height", gt=0.0, le=50.0),
        air_density=t.number("air_density", 1.225, gt=0.0, le=10.0),
        rotor_hz=t.number("rotor_hz", 4.5, gt=0.0, le=100.0),
        threshold_friction_velocity=t.number("threshold_friction_velocity", 0.25, gt=0.0),
        roughness_length=t.number("roughness_length", 1e-3, gt=0.0, le=1.0),
        wand_origin=t.floats("wand_origin", 3, (0.0, 0.0, 0.0)),
        wand_scale=t.number("wand_scale", 10.0, gt=0.0, le=1e4),
        response_time=t.number("response_time", 1.0, gt=0.0, le=60.0),
        timeline=tuple(keys),
    )


def forces(t: Table) -> Forces:
    drag = None
    if t.has("drag"):
        d = t.table("drag", ("air_viscosity",))
        drag = Drag(air_viscosity=d.number("air_viscosity", AIR_VISCOSITY, gt=0.0))
    return Forces(
        gravity=t.floats("gravity", 3, None),
        drag=drag,
        damping=t.number("damping", None, gt=0.0),
    )


def _params(t: Table, kind: FieldKind) -> dict[str, object]:
    """The kind-specific [field.params], defaults filled in so consumers need none."""
    if kind is FieldKind.UNIFORM:
        return {"velocity": t.floats("velocity", 3)}
    if kind is FieldKind.VORTEX:
        return {
            "center": t.floats("center", 2),
            "circulation": t.number("circulation"),
            "core_radius": t.number("core_radius", gt=0.0),
            "axial_speed": t.number("axial_speed", 0.0),
        }
    if kind is FieldKind.DOWNWASH:
        params = {
            "rotor_center": t.floats("rotor_center", 3),
            "rotor_radius": t.number("rotor_radius", gt=0.0),
            "induced_velocity": t.number("induced_velocity", ge=0.0),
            "ground_height": t.number("ground_height", 0.0),
        }
        if params["rotor_center"][2] <= params["ground_height"]:  # type: ignore[index,operator]
            raise t.fail("rotor_center", f"must have z > {t.sub('ground_height')} = "
                                         f"{params['ground_height']!r}: the rotor is above ground")
        return params
    return {}


PARAM_KEYS = {
    FieldKind.UNIFORM: ("velocity",),
    FieldKind.VORTEX: ("center", "circulation", "core_radius", "axial_speed"),
    FieldKind.DOWNWASH: ("rotor_center", "rotor_radius", "induced_velocity", "ground_height"),
    FieldKind.FILE: (),
    FieldKind.ROTOR: (),
}


def _npy_shape(path: Path, array: str) -> tuple[int, ...]:
    """The shape of `array` inside the .npz at `path`, from its .npy header alone."""
    with zipfile.ZipFile(path) as archive, archive.open(f"{array}.npy") as f:
        version = npy_format.read_magic(f)
        if version == (1, 0):
            return npy_format.read_array_header_1_0(f)[0]
        if version == (2, 0):
            return npy_format.read_array_header_2_0(f)[0]
        raise ValueError(f"unsupported .npy format version {version}")


def _file_resolution(t: Table, path: Path) -> tuple[int, int, int]:
    """The (nx, ny, nz) of a kind="file" field, from its "velocity" array (nz, ny, nx, 3).

    The layout is the one `cavesim.fields` reads and writes: x varies fastest, as in the 3D
    texture. Values (dtype, finiteness) are checked there, when the grid is built.
    """
    lo, hi = FIELD_RESOLUTION_RANGE
    allowed = (f"must be an .npz holding an array 'velocity' of shape (nz, ny, nx, 3), "
               f"each n in {lo}..{hi}, nx*ny*nz <= {MAX_FIELD_NODES}")
    try:
        shape = _npy_shape(path, "velocity")
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as e:
        raise t.fail("file", f"{allowed} ({path}: {type(e).__name__}: {e})") from e
    if (len(shape) != 4 or shape[3] != 3 or not all(lo <= n <= hi for n in shape[:3])
            or math.prod(shape[:3]) > MAX_FIELD_NODES):
        raise t.fail("file", f"{allowed} ({path} holds shape {shape})")
    nz, ny, nx = shape[:3]
    return nx, ny, nz


def field(t: Table, base: Path) -> Field:
    """The [field] table; a relative `file` resolves against `base`."""
    kind = t.choice("kind", FieldKind)
    box_min = t.floats("box_min", 3)
    box_max = t.floats("box_max", 3)
    if not all(a < b for a, b in zip(box_min, box_max, strict=True)):
        raise t.fail("box_max", f"must be > {t.sub('box_min')} = {list(box_min)!r} on every axis")
    if kind is FieldKind.FILE:
        if t.has("resolution"):
            raise t.fail("resolution", 'not allowed with kind = "file": the file decides')
        path = t.existing_file("file", base)
        resolution = _file_resolution(t, path)
    elif kind is FieldKind.ROTOR:  # no grid: evaluated on the GPU from the frame's rotor
        for key in ("file", "resolution"):
            if t.has(key):
                raise t.fail(key, 'not allowed with kind = "rotor": the flow has no grid')
        path, resolution = None, (2, 2, 2)
    else:
        if t.has("file"):
            raise t.fail("file", f'only allowed with kind = "file", not {kind.value!r}')
        path = None
        lo, hi = FIELD_RESOLUTION_RANGE
        resolution = t.ints("resolution", 3, ge=lo, le=hi)
        if math.prod(resolution) > MAX_FIELD_NODES:
            raise t.fail("resolution", f"must have at most {MAX_FIELD_NODES} nodes in all")
    params = t.table("params", PARAM_KEYS[kind])
    return Field(
        kind=kind,
        box_min=box_min,
        box_max=box_max,
        resolution=resolution,  # type: ignore[arg-type]
        out_of_domain=t.choice("out_of_domain", OutOfDomain, OutOfDomain.CLAMP),
        sampling=t.choice("sampling", FieldSampling, FieldSampling.MANUAL),
        params=_params(params, kind),
        file=path,
    )


def collision(t: Table, base: Path) -> Collision:
    """The [collision] table; a relative heightfield `file` resolves against `base`."""
    kind = t.choice("kind", CollisionKind)
    if kind is CollisionKind.PLANE:
        if t.has("file"):
            raise t.fail("file", 'only allowed with kind = "heightfield"')
        height, path = t.number("height", 0.0), None
    else:
        if t.has("height"):
            raise t.fail("height", 'only allowed with kind = "plane"; the file holds heights')
        height, path = 0.0, t.existing_file("file", base)
    return Collision(
        kind=kind,
        friction=t.number("friction", ge=0.0, le=1.0),
        resilience=t.number("resilience", ge=0.0, le=1.0),
        friction_min_speed=t.number("friction_min_speed", 0.0, ge=0.0),
        height=height,
        file=path,
    )
