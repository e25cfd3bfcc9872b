"""Scene files in, frozen `Scene` out: the one place a scene's TOML is read and checked.

Everything downstream (shader defines, the GL engine, the numpy twin) trusts a `Scene`, so
every rule of the schema is enforced here and broken input fails with a `SceneError` that
names the file, the dotted key, the value and what is allowed. Each table is checked
against its dataclass in `model.py` or `file.py` (by `cavesim.core._schema`); what those cannot
say is here: the rules between keys and tables, and the conversions where the file differs
from the model.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

from cavesim.core._schema import Source, Table, unique_names
from cavesim.core._toml import read_toml
from cavesim.core.errors import FieldError, SceneError
from cavesim.core.features.collision import Collision, CollisionKind
from cavesim.core.fields.flow_files import FLOW_FILE_SUFFIXES, read_flow_file
from cavesim.core.fields.npz_field import npz_layout
from cavesim.core.fields.regular_grid import check_box, npz_corners
from cavesim.core.limits import (
    MAX_EMITTERS,
    MAX_FIELD_SERIES_NODES,
    MAX_PARTICLE_CLASSES,
    MAX_RATE,
)
from cavesim.core.scene.file import FIELD_PARAMS, SceneFile
from cavesim.core.scene.model import (
    Emitter,
    Field,
    FieldKind,
    Helicopter,
    Motion,
    ParticleClass,
    Scene,
)


def load_scene(path: str | Path) -> Scene:
    """Read and check the scene file at `path`; `Scene.source` is `path` as given. A file
    with a `base` extends that scene file: its top-level keys replace the base's, its
    tables are merged key by key into the base's, its arrays of tables replace the base's."""
    path = Path(path)
    data = read_toml(path, SceneError, "scene file")
    if "base" in data:
        data = _extended(path, data)
    return parse_scene(data, path, path.stem)


def _extended(path: Path, data: dict[str, Any]) -> dict[str, Any]:
    """`data` laid over the scene file its `base` names (which may not have a base)."""
    base = data["base"]
    if not isinstance(base, str) or not base:
        raise SceneError(f"{path}: base = {base!r} is not allowed: must be the path of a scene "
                         f"file, relative to this one")
    base_path = path.parent / base
    under = read_toml(base_path, SceneError, f"base scene file of {path}")
    if "base" in under:
        raise SceneError(f"{path}: base = {base!r} is not allowed: {base_path} has a base of "
                         f"its own; a scene extends one file at most")
    return _merged(under, {key: value for key, value in data.items() if key != "base"})


def _merged(under: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    merged = dict(under)
    for key, value in over.items():
        below = merged.get(key)
        merged[key] = _merged(below, value) if isinstance(below, dict) and isinstance(
            value, dict) else value
    return merged


def parse_scene(data: Mapping[str, Any], source: Path | None = None,
                name: str | None = None) -> Scene:
    """Check a scene given as the dict `tomllib` would produce.

    `source` names the file in errors ("<dict>" when None) and is the directory that
    relative `file` paths resolve against (the working directory when None). `name` is the
    scene name when the data has no `name` key (default: the stem of `source`, or "scene").
    """
    top = Table(Source.of(source, SceneError), "", data, SceneFile)
    scene_name = top.get("name", default=name or (source.stem if source is not None else "scene"))
    sim = top.get("simulation")

    class_tables = top.tables("particle_class")
    classes = tuple(_particle_class(t) for t in class_tables)
    unique_names(class_tables, (c.name for c in classes))
    class_index = {c.name: i for i, c in enumerate(classes)}
    emitter_tables = top.tables("emitter")
    emitters = tuple(_emitter(t, class_index) for t in emitter_tables)
    unique_names(emitter_tables, (e.name for e in emitters))
    emitters = _scaled(top, emitters)
    for key, tables, most in (("particle_class", classes, MAX_PARTICLE_CLASSES),
                              ("emitter", emitters, MAX_EMITTERS)):
        if len(tables) > most:
            raise top.source.fail(f"{key}: {len(tables)} [[{key}]] tables, at most {most} "
                                  f"allowed (the engine's limit for any GL 4.3 driver)")

    forces = top.get("forces")
    field = _field(top.table("field")) if top.has("field") else None
    collision = _collision(top.table("collision")) if top.has("collision") else None

    helicopter = _helicopter(top.table("helicopter")) if top.has("helicopter") else None
    needs_rotor = [f"emitter[{i}]" for i, e in enumerate(emitters) if e.follow_helicopter]
    if field is not None and field.kind is FieldKind.ROTOR:
        needs_rotor.append("field.kind = 'rotor'")
    if needs_rotor and helicopter is None:
        raise top.source.fail(f"helicopter is missing: required by {', '.join(needs_rotor)}")
    scene = Scene(name=scene_name, source=source, **asdict(sim), particle_classes=classes,
                  emitters=emitters, forces=forces, field=field, collision=collision,
                  helicopter=helicopter)
    # the features complete the scene (a class's drag law, the origin) and check their rules;
    # they import this package's model: imported when a scene is parsed, so that a feature
    # imported first finds the model whole
    from cavesim.core.features.registry import completed

    return completed(scene)


def _particle_class(t: Table) -> ParticleClass:
    """A [[particle_class]]: an inertial one has a density; a tracer no density and no
    drag law (nothing about its inertia)."""
    particle = t.build()
    if particle.motion is Motion.TRACER:
        for key in ("density", "drag"):
            t.forbid(key, 'only for an inertial class: a tracer has no inertia (a tracer '
                          'class allows name, diameter and motion)')
    elif particle.density is None:
        raise t.source.fail(f"{t.sub('density')} is missing: required for an inertial class "
                            '(a number > 0, kg/m³), or motion = "tracer"')
    return particle


def _scaled(top: Table, emitters: tuple[Emitter, ...]) -> tuple[Emitter, ...]:
    """The emitters with their rates times the file's `emission_scale`."""
    scale = top.get("emission_scale")
    if too_fast := [e for e in emitters if e.rate * scale > MAX_RATE]:
        raise top.bad("emission_scale", f"makes emitter {too_fast[0].name!r}'s rate "
                                         f"{too_fast[0].rate * scale:g} per second; at most "
                                         f"{MAX_RATE:g} allowed")
    return tuple(dataclasses.replace(e, rate=e.rate * scale) for e in emitters)


def _emitter(t: Table, class_index: Mapping[str, int]) -> Emitter:
    """An [[emitter]]; `class_index` maps particle class names to their index."""
    class_name = t.get("particle_class", str)  # the file names the class, the model indexes
    if class_name not in class_index:
        names = ", ".join(repr(n) for n in class_index) or "none are defined"
        raise t.bad("particle_class", f"must name a [[particle_class]]: {names}")
    direction = t.get("direction")
    norm = math.hypot(*direction)
    emitter = t.build(particle_class=class_index[class_name],
                      direction=tuple(x / norm for x in direction))
    if emitter.speed_spread > emitter.speed:  # a speed drawn from speed ± spread must be >= 0
        raise t.bad("speed_spread", f"must be a finite number >= 0 and <= {t.sub('speed')} "
                                    f"= {emitter.speed!r}")
    return emitter


def _helicopter(t: Table) -> Helicopter:
    """The [helicopter] table, its scripted wand [[helicopter.timeline]] keys in order."""
    helicopter = t.build()
    tables, keys = t.tables("timeline"), helicopter.timeline
    for i in range(1, len(keys)):
        if keys[i].t <= keys[i - 1].t:
            raise tables[i].bad("t", f"must be > the previous key's t = {keys[i - 1].t!r}: "
                                     "keys in order")
    return helicopter


def _field(t: Table) -> Field:
    """The [field] table: which keys it takes and its [field.params] depend on its kind."""
    kind = t.get("kind")
    t.forbid("times", "not a key: a file's time coordinate, or a rotating field's snapshots, "
                      "give a time series its times")
    given: dict[str, Any] = {}
    if kind is FieldKind.FILE:
        t.forbid("resolution", 'not allowed with kind = "file": the file decides')
        given["file"] = t.get("file", required=True)
        if given["file"].suffix.lower() in FLOW_FILE_SUFFIXES:
            given.update(_flow_file_grid(t, given["file"]))
        else:
            for key in FLOW_FILE_KEYS:
                t.forbid(key, "only allowed with a .nc or .vti file: an .npz is in m, s and m/s")
            given["resolution"], given["times"] = _file_resolution(t, given["file"])
            given.update(_npz_box(t, given["file"]))
    else:
        for key in ("file", *FLOW_FILE_KEYS):
            t.forbid(key, f'only allowed with kind = "file", not {kind.value!r}')
    if kind is FieldKind.ROTOR:  # no grid: evaluated on the GPU from the frame's rotor
        for key in ("resolution", "interpolation"):
            t.forbid(key, 'not allowed with kind = "rotor": the flow has no grid')
        given["resolution"] = (2, 2, 2)
    params_table = t.table("params", FIELD_PARAMS[kind])
    params = params_table.build()
    if kind is FieldKind.ROTATING:
        given["times"] = params.times()
        nodes = math.prod(t.get("resolution")) * params.snapshots
        if nodes > MAX_FIELD_SERIES_NODES:
            raise params_table.bad("snapshots", f"{params.snapshots} snapshots of "
                                                f"{t.sub('resolution')} make {nodes:,} nodes; "
                                                f"at most MAX_FIELD_SERIES_NODES = "
                                                f"{MAX_FIELD_SERIES_NODES:,} are allowed")
    if kind is FieldKind.DOWNWASH and params.rotor_center[2] <= params.ground_height:
        raise params_table.bad("rotor_center", f"must have z > {params_table.sub('ground_height')}"
                                               f" = {params.ground_height!r}: the rotor is "
                                               "above ground")
    field = t.build(params=asdict(params), **given)
    if not all(a < b for a, b in zip(field.box_min, field.box_max, strict=True)):
        raise t.bad("box_max", f"must be > {t.sub('box_min')} = {list(field.box_min)!r} on "
                               "every axis")
    return field


def _collision(t: Table) -> Collision:
    """The [collision] table: a plane has a height, a height field a file."""
    if t.get("kind") is CollisionKind.PLANE:
        t.forbid("file", 'only allowed with kind = "heightfield"')
        return t.build()
    t.forbid("height", 'only allowed with kind = "plane"; the file holds heights')
    return t.build(file=t.get("file", required=True))


FLOW_FILE_KEYS = ("variables", "vector", "velocity_units", "length_units",  # .nc, .vti
                  "time_units")
NPZ_BOX_RTOL = 1e-9  # how far an .npz's own box may stray from the scene's: of value and extent


def _flow_file_grid(t: Table, path: Path) -> dict[str, Any]:
    """The resolution and box of a .nc or .vti field, from the file; the scene gives no box.
    The box is read here only, in world coordinates, for `[simulation] origin` to move."""
    for key in ("box_min", "box_max"):
        t.forbid(key, f"not allowed with a {path.suffix} file: its coordinates give the box")
    if path.suffix.lower() == ".vti":
        t.forbid("variables", "only allowed with a .nc file; a .vti file's array is `vector`")
        t.forbid("time_units", "only allowed with a .nc file; a .vti file holds one snapshot")
        vector = t.get("vector")
        named = None if vector is None else (vector,)
    else:
        t.forbid("vector", "only allowed with a .vti file; a .nc file's are `variables`")
        named = t.get("variables")
    try:
        flow = read_flow_file(path, named, t.get("velocity_units"), t.get("length_units"),
                              t.get("time_units"))
    except FieldError as e:
        raise t.bad("file", str(e)) from e
    nz, ny, nx = flow.velocity.shape[1:4]
    return {"resolution": (nx, ny, nz), "box_min": flow.box_min, "box_max": flow.box_max,
            "times": flow.times if len(flow.times) > 1 else None}


def _file_resolution(t: Table, path: Path
                     ) -> tuple[tuple[int, int, int], tuple[float, ...] | None]:
    """The (nx, ny, nz) of a kind="file" .npz field and its times (None: steady), from its
    headers and its times alone (`cavesim.core.fields.npz_field`); its values (dtype,
    finiteness) are checked where the grid is built."""
    try:
        layout = npz_layout(path)
    except FieldError as e:
        raise t.bad("file", str(e)) from e
    return layout.resolution, layout.times


def _npz_box(t: Table, path: Path) -> dict[str, tuple[float, ...]]:
    """The box of an .npz field: box_min and box_max from the scene, else the file's arrays
    of those names (as `save_field` writes them); given by both, they must agree. Both are
    world coordinates here: `[simulation] origin` moves the field's box afterwards."""
    try:
        held = npz_corners(path, 3)
    except FieldError as e:
        raise t.bad("file", str(e)) from e
    box = {}
    for key in ("box_min", "box_max"):
        if not t.has(key) and key not in held:
            raise t.source.fail(f"{t.sub(key)} is missing: required, a list of 3 finite "
                                f"numbers, as {path} holds no array {key!r} (which would give it)")
        box[key] = t.get(key) if t.has(key) else held[key]
    extents = [abs(b - a) for a, b in zip(box["box_min"], box["box_max"], strict=True)]
    for key in (k for k in ("box_min", "box_max") if k in held and t.has(k)):
        if not all(math.isclose(f, s, rel_tol=NPZ_BOX_RTOL, abs_tol=NPZ_BOX_RTOL * e)
                   for f, s, e in zip(held[key], box[key], extents, strict=True)):
            raise t.bad(key, f"must agree with {path}'s array {key!r} = {list(held[key])} (to "
                             f"{NPZ_BOX_RTOL:g} relative, in world coordinates), or be left "
                             "out: the file gives the box")
    if any(key in held and not t.has(key) for key in box):
        try:
            check_box(box["box_min"], box["box_max"], 3, f"{path}: the field's")
        except FieldError as e:
            raise t.bad("file", str(e)) from e
    return box
