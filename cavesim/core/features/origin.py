"""A scene placed far from the world's origin, stepped near its own ([simulation] origin).

float32 holds a position 5 km out to about 0.5 mm, and a step's increment loses what falls
below that: the float32 floor of a scene grows with its distance from the origin (2e-6 m
at 500 m at 1/960 s, far more at kilometres). `[simulation] origin` names the world
position of the scene's own origin. The scene file keeps world coordinates; the loader
takes `origin` from every coordinate the scene holds, so the engine, both twins, the
renderer and the helicopter's flight all work near zero, with the floor of a scene at the
world's origin.

Which keys are coordinates is said where each key is declared, by the mark
`Coordinate(axes)` (cavesim.core._schema) beside its type, in any table of the scene, the
[field.params] of each field kind included: `relative_to_origin` moves every marked key it
finds, so a key a new feature adds moves by being marked. A flow file's box is the field's,
read once by the loader and moved with the rest (its grid takes it:
`cavesim.core.fields.grid`); the height field's file is read relative to the origin
(`cavesim.core.fields.heights.load_heightfield`). What is not a coordinate (velocities, the
wand's room positions, sizes) is left alone; positions in outputs are relative to it.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from typing import Annotated, Any

from cavesim.core._schema import Coordinate
from cavesim.core.features.feature import Feature
from cavesim.core.scene.file import FIELD_PARAMS
from cavesim.core.scene.model import Field, Scene, Vec3

AXES = "xyz"


class Origin(Feature):
    name = "origin"
    keys = ("simulation.origin",)

    def present(self, scene):
        return scene.origin is not None

    def complete(self, scene):
        return relative_to_origin(scene)


ORIGIN = Origin()


def relative_to_origin(scene: Scene) -> Scene:
    """`scene` with `scene.origin` taken from every coordinate it holds (the same scene when
    it names none)."""
    if scene.origin is None:
        return scene
    return _moved(scene, scene.origin)


def coordinates(table: type) -> dict[str, Coordinate]:
    """The keys of a table's dataclass that hold coordinates, and which axes each holds."""
    return dict(_coordinates(table))


@functools.cache
def _coordinates(table: type) -> tuple[tuple[str, Coordinate], ...]:
    hints = typing.get_type_hints(table, include_extras=True)
    return tuple((name, mark) for name, hint in hints.items()
                 if (mark := _mark(hint)) is not None)


def _mark(hint: Any) -> Coordinate | None:
    """The Coordinate mark of a type hint, also inside `X | None`."""
    if typing.get_origin(hint) is Annotated:
        return next((m for m in hint.__metadata__ if isinstance(m, Coordinate)), None)
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return next((mark for arg in typing.get_args(hint) if (mark := _mark(arg))), None)
    return None


def _moved(value: Any, origin: Vec3) -> Any:
    """`value` (a table, an array of tables, anything else) with its coordinates moved."""
    if isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
        return tuple(_moved(item, origin) for item in value)
    if not dataclasses.is_dataclass(value):
        return value
    marks = coordinates(type(value))
    changes = {}
    for field in dataclasses.fields(value):
        held = getattr(value, field.name)
        if held is None:
            continue
        if field.name in marks:
            changes[field.name] = _shifted(held, marks[field.name], origin)
        elif isinstance(value, Field) and field.name == "params":
            changes[field.name] = _moved_params(held, FIELD_PARAMS[value.kind], origin)
        elif (moved := _moved(held, origin)) is not held:
            changes[field.name] = moved
    return dataclasses.replace(value, **changes) if changes else value


def _moved_params(params: dict[str, object], table: type, origin: Vec3) -> dict[str, object]:
    """A field kind's [field.params], as a dict, with the keys its table marks moved."""
    return {key: _shifted(held, mark, origin) if (mark := coordinates(table).get(key))
            else held for key, held in params.items()}


def _shifted(held: Any, mark: Coordinate, origin: Vec3) -> Any:
    """A coordinate (one axis: a number; several: a list of as many or fewer, in order)
    minus the origin's same axes."""
    offsets = [origin[AXES.index(axis)] for axis in mark.axes]
    if isinstance(held, int | float):
        return float(held) - offsets[0]
    return tuple(float(p) - o for p, o in zip(held, offsets, strict=False))
