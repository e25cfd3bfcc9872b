"""A scene placed far from the world's origin, stepped near its own.

float32 holds a position 5 km out to about 0.5 mm, and a step's increment loses what falls
below that: the float32 floor of a scene grows with its distance from the origin (2e-6 m
at 500 m at 1/960 s, far more at kilometres). `[simulation] origin` names the world
position of the scene's own origin. The scene file keeps world coordinates; the loader
takes `origin` from every coordinate the scene holds, so the engine, both twins, the
renderer and the helicopter's flight all work near zero, with the floor of a scene at the
world's origin. A flow file's box is the field's, read once by the loader and moved here
with the rest (its grid takes it: `cavesim.core.fields.grid`); the height field's file is
read relative to the origin (`cavesim.core.fields.heights.load_heightfield`). What is not a
coordinate (velocities, the wand's room positions, sizes) is left alone; positions in
outputs are relative to it.
"""

from __future__ import annotations

import dataclasses

from cavesim.core.scene.model import Scene, Vec3


def relative_to_origin(scene: Scene) -> Scene:
    """`scene` with `scene.origin` taken from every coordinate it holds (the same scene when
    it names none)."""
    origin = scene.origin
    if origin is None:
        return scene
    field = scene.field
    if field is not None:
        field = dataclasses.replace(field, box_min=_moved(field.box_min, origin),
                                    box_max=_moved(field.box_max, origin),
                                    params=_moved_params(field.params, origin))
    collision = scene.collision
    if collision is not None:
        collision = dataclasses.replace(collision, height=collision.height - origin[2])
    helicopter = scene.helicopter
    if helicopter is not None:
        helicopter = dataclasses.replace(helicopter,
                                         wand_origin=_moved(helicopter.wand_origin, origin))
    emitters = tuple(dataclasses.replace(e, position=_moved(e.position, origin))
                     for e in scene.emitters)
    return dataclasses.replace(scene, field=field, collision=collision,
                               helicopter=helicopter, emitters=emitters)


def _moved(point, origin: Vec3) -> tuple[float, ...]:
    return tuple(float(p) - o for p, o in zip(point, origin, strict=False))


def _moved_params(params: dict[str, object], origin: Vec3) -> dict[str, object]:
    """An analytic field's parameters: its centres (x, y or x, y, z) and its ground
    height move; rates and sizes do not."""
    moved = dict(params)
    for key in ("center", "rotor_center"):
        if key in moved:
            moved[key] = _moved(moved[key], origin)
    if "ground_height" in moved:
        moved["ground_height"] = float(moved["ground_height"]) - origin[2]
    return moved
