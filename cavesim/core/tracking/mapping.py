"""Which DTrack body is the head and which the wand, and where DTrack's room lies in the
CAVE's: the tracker bridge's mapping file (config/tracking/dtrack.toml).

A point p (mm) in DTrack's room lies at  R_room · p / 1000 + room.offset  in the CAVE's (m,
z up, the viewer facing +y), with R_room = yaw about the CAVE's z after `room.axes`.
A target (head or wand) follows one body or Flystick whose rotation body → DTrack room is
R_body; the target's frame has `axes` in the body's frame, so it turns by
R_room · R_body · A_targetᵀ, and its point sits `offset` (m, in its own frame) from the
body's origin. The head's frame looks along +y with +x to its right and +z up
(`cavesim.core.cave.projection`); the wand's points along +y
(`cavesim.core.helicopter.flight`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import numpy as np

from cavesim.core._schema import Note, Range, Rule, Source, Table
from cavesim.core._toml import read_toml
from cavesim.core.errors import TrackerError
from cavesim.core.tracking.dtrack import Body
from cavesim.core.tracking.rotation import (
    IDENTITY_AXES,
    axes_matrix,
    is_frame,
    quaternion_of,
    yaw_matrix,
)

MM = 1e-3  # m per DTrack millimetre
MAX_OFFSET = 100.0  # m: offsets in a room, not across a campus

Axes = Annotated[tuple[str, str, str], Rule(
    "x, y and z once each, '-' for a reversed axis, turning and not mirroring, "
    'e.g. ["x", "-z", "y"]', is_frame)]
Offset = Annotated[tuple[float, float, float], Range.within((-MAX_OFFSET, MAX_OFFSET))]
Id = Annotated[int, Range(ge=0), Note("DTrack's id, counted from 0")]


class Tracked(Enum):
    """Where a target's pose comes from: a line of DTrack's output."""

    BODY = "6d"
    FLYSTICK = "6df2"


@dataclass(frozen=True)
class Target:
    """The head or the wand: which body it follows, its axes and its offset from it."""

    tracked: Tracked
    id: int
    axes: tuple[str, str, str] = IDENTITY_AXES  # its x, y, z as the body's signed axes
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m, in its own frame


@dataclass(frozen=True)
class TrackerMapping:
    """DTrack's room in the CAVE's, and the head and wand (either may be absent)."""

    head: Target | None = None
    wand: Target | None = None
    axes: tuple[str, str, str] = IDENTITY_AXES  # the CAVE's x, y, z as DTrack's signed axes
    yaw: float = 0.0  # degrees about the CAVE's z, after `axes`
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m: DTrack's origin in the CAVE

    def pose(self, target: Target, body: Body) -> tuple[tuple[float, float, float],
                                                        tuple[float, float, float, float]]:
        """`target`'s position (m) and orientation (x, y, z, w) in the CAVE from its body's
        tracked pose."""
        room = yaw_matrix(self.yaw) @ axes_matrix(self.axes)
        turn = room @ np.array(body.rotation) @ axes_matrix(target.axes).T
        position = (room @ (MM * np.array(body.position)) + np.array(self.offset)
                    + turn @ np.array(target.offset))
        return tuple(position.tolist()), quaternion_of(turn)


# --- the file ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RoomTable:
    axes: Axes = IDENTITY_AXES
    yaw: Annotated[float, Range.within((-360.0, 360.0)),
                   Note("degrees about the CAVE's z, counter-clockwise from above")] = 0.0
    offset: Annotated[Offset, Note("[x, y, z] in metres: DTrack's origin in the CAVE")] = (
        0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TargetTable:
    body: Id | None = None
    flystick: Id | None = None
    axes: Axes = IDENTITY_AXES
    offset: Annotated[Offset, Note("[x, y, z] in metres, in the target's own frame")] = (
        0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MappingFile:
    """The top level of a mapping file."""

    room: RoomTable = RoomTable()
    head: TargetTable | None = None
    wand: TargetTable | None = None


def load_mapping(path: str | Path) -> TrackerMapping:
    """Read and check the mapping file at `path` (see config/tracking/dtrack.toml)."""
    path = Path(path)
    return parse_mapping(read_toml(path, TrackerError, "tracker mapping"), path)


def parse_mapping(data: Mapping[str, Any], source: Path | None = None) -> TrackerMapping:
    """Check a mapping given as the dict `tomllib` would produce; `source` names it."""
    top = Table(Source.of(source, TrackerError), "", data, MappingFile)
    room = top.table("room").build()
    targets = {name: _target(top.table(name)) for name in ("head", "wand") if top.has(name)}
    if not targets:
        raise top.source.fail("head and wand are missing: a mapping needs a [head] table, "
                              "a [wand] table or both")
    return TrackerMapping(targets.get("head"), targets.get("wand"), room.axes, room.yaw,
                          room.offset)


def _target(t: Table) -> Target:
    """A [head] or [wand]: exactly one of `body` and `flystick`, then its axes and offset."""
    table = t.build()
    if t.has("body"):
        t.forbid("flystick", f"{t.sub('body')} is given too; a {t.key} follows one body")
        return Target(Tracked.BODY, table.body, table.axes, table.offset)
    if t.has("flystick"):
        return Target(Tracked.FLYSTICK, table.flystick, table.axes, table.offset)
    raise t.source.fail(f"{t.sub('body')} is missing: required, body = ID (a 6d body) or "
                        f"flystick = ID (a 6df2 Flystick), DTrack's id counted from 0")
