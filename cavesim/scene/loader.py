"""Scene files in, frozen `Scene` out: the one place a scene's TOML is read and checked.

Everything downstream (shader defines, the GL engine, the numpy twin) trusts a `Scene`, so
every rule of the schema is enforced here and broken input fails with a `SceneError` that
names the file, the dotted key, the value and what is allowed.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cavesim._toml import read_toml
from cavesim.errors import SceneError
from cavesim.limits import MAX_EMITTERS, MAX_PARTICLE_CLASSES
from cavesim.scene import _sections
from cavesim.scene._checks import Table
from cavesim.scene.model import FieldKind, Forces, Scene

TOP_KEYS = ("name", "simulation", "particle_class", "emitter", "forces", "field", "collision",
            "helicopter")


def load_scene(path: str | Path) -> Scene:
    """Read and check the scene file at `path`; `Scene.source` is `path` as given."""
    path = Path(path)
    return parse_scene(read_toml(path, SceneError, "scene file"), path, path.stem)


def parse_scene(data: Mapping[str, Any], source: Path | None = None,
                name: str | None = None) -> Scene:
    """Check a scene given as the dict `tomllib` would produce.

    `source` names the file in errors ("<dict>" when None) and is the directory that
    relative `file` paths resolve against (the working directory when None). `name` is the
    scene name when the data has no `name` key (default: the stem of `source`, or "scene").
    """
    src = str(source) if source is not None else "<dict>"
    base = (source.parent if source is not None else Path()).absolute()
    top = Table(src, "", data, TOP_KEYS)
    default_name = name or (source.stem if source is not None else "scene")
    scene_name = top.string("name", default_name)

    if not top.has("simulation"):
        raise SceneError(f"{src}: simulation is missing: required, a [simulation] table")
    sim = _sections.simulation(top.table("simulation", _sections.SIMULATION_KEYS))

    classes = []
    first_use: dict[str, str] = {}
    for i, raw in enumerate(top.tables("particle_class")):
        t = Table(src, f"particle_class[{i}]", raw, _sections.PARTICLE_CLASS_KEYS)
        c = _sections.particle_class(t)
        _check_unique(t, c.name, first_use)
        classes.append(c)
    class_index = {c.name: i for i, c in enumerate(classes)}

    emitters = []
    first_use = {}
    for i, raw in enumerate(top.tables("emitter")):
        t = Table(src, f"emitter[{i}]", raw, _sections.EMITTER_KEYS)
        e = _sections.emitter(t, class_index)
        _check_unique(t, e.name, first_use)
        emitters.append(e)

    for key, tables, most in (("particle_class", classes, MAX_PARTICLE_CLASSES),
                              ("emitter", emitters, MAX_EMITTERS)):
        if len(tables) > most:
            raise SceneError(f"{src}: {key}: {len(tables)} [[{key}]] tables, at most {most} "
                             f"allowed (the engine's limit for any GL 4.3 driver)")

    forces = Forces()
    if top.has("forces"):
        forces = _sections.forces(top.table("forces", _sections.FORCES_KEYS))
    if forces.drag is not None and not top.has("field"):
        raise SceneError(f"{src}: field is missing: required because forces.drag is present "
                         "(drag pulls particles toward the [field] flow)")
    if forces.drag is None and top.has("field"):
        kind = top.data["field"].get("kind") if isinstance(top.data["field"], Mapping) else None
        raise SceneError(f"{src}: field (kind = {kind!r}) is not allowed: only together with "
                         "forces.drag, which is missing (without drag nothing samples the field)")
    field = None
    if top.has("field"):
        field = _sections.field(top.table("field", _sections.FIELD_KEYS), base)
    collision = None
    if top.has("collision"):
        collision = _sections.collision(top.table("collision", _sections.COLLISION_KEYS), base)

    helicopter = None
    if top.has("helicopter"):
        helicopter = _sections.helicopter(top.table("helicopter", _sections.HELICOPTER_KEYS))
    needs_rotor = [f"emitter[{i}]" for i, e in enumerate(emitters) if e.follow_helicopter]
    if field is not None and field.kind is FieldKind.ROTOR:
        needs_rotor.append("field.kind = 'rotor'")
    if needs_rotor and helicopter is None:
        raise SceneError(f"{src}: helicopter is missing: required by {', '.join(needs_rotor)}")

    return Scene(name=scene_name, source=source, particle_classes=tuple(classes),
                 emitters=tuple(emitters), forces=forces, field=field, collision=collision,
                 helicopter=helicopter, **sim)


def _check_unique(t: Table, name: str, first_use: dict[str, str]) -> None:
    if name in first_use:
        raise t.fail("name", f"must be unique; {first_use[name]}.name has it already")
    first_use[name] = t.key
