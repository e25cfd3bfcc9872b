"""The CAVE's screens in room coordinates, and the TOML file that describes them.

A `Cave` is read once at start-up (`load_cave`) and handed to the renderer, which makes
one off-axis projection per `Wall` from the tracked head (`cavesim.core.cave.projection`).
Room coordinates are metres, z up, floor at z = 0. A wall is given by three corners
seen from inside the room: `lower_left`, `lower_right`, `upper_left`; its `normal` points
from the screen toward the viewer. A wall may name the EGL device (`gpu`) its node computes
on; `cavesim run` spreads the other walls over the machine's GPUs. A wall may name the
`node` that draws it: walls with one node share its context, which steps the particles
once a frame and draws each of them (default: every wall its own node, named after it).
The file's tables are `CaveFile` and `WallTable`, read by `cavesim.core._schema`;
`parse_cave` adds the geometry.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import numpy as np

from cavesim.core._schema import Note, Range, Rule, Source, Table, unique_names
from cavesim.core._toml import read_toml
from cavesim.core.errors import CaveError
from cavesim.core.limits import GPU_RANGE, NAME_RE, WALL_RESOLUTION_RANGE

MIN_EDGE_M = 1e-6  # shorter edges make a wall of no area
MAX_COS = 1e-6  # |cos| of the angle between the bottom and left edges of a rectangle
CORNER_TOL_M = 1e-6  # how far a given upper_right may sit from the one the rectangle implies
ASPECT_TOL = 0.01  # pixels may be 1% away from square
DEFAULT_EYE_SEPARATION = 0.064  # m, an adult's interpupillary distance


def _is_name(text: str) -> bool:
    return NAME_RE.fullmatch(text) is not None


Name = Annotated[str, Rule("1-32 characters, each a letter, digit, '_' or '-'", _is_name)]
Point = Annotated[tuple[float, float, float], Note("[x, y, z] in metres")]


class StereoMode(StrEnum):
    """How a wall shows two eyes: not at all, in the driver's left and right back buffers
    (quad-buffered), or frame-packed for passive/active 3D projectors."""

    MONO = "mono"
    QUAD = "quad"
    SIDE_BY_SIDE = "side_by_side"
    TOP_BOTTOM = "top_bottom"


def _positive_size(rect: tuple[int, int, int, int]) -> bool:
    return rect[2] > 0 and rect[3] > 0


@dataclass(frozen=True, kw_only=True)
class Display:
    """How a wall's node shows it live (`cavesim node --display`): the [wall.display] table."""

    x_display: str | None = None  # the X display, e.g. ":0.1" (default: the node's DISPLAY)
    monitor: Annotated[int, Range(ge=0), Note("a GLFW monitor index")] | None = None
    # fullscreen on `monitor` (default: the primary) at its video mode, the picture scaled
    fullscreen: bool = False
    window: Annotated[tuple[int, int, int, int], Rule("[x, y, width, height] in pixels with "
                                                      "width and height > 0", _positive_size)
                      ] | None = None  # default: the wall's resolution, the walls side by side
    vsync: bool = True  # swap on the display's vertical blank
    # quad: the driver's left and right back buffers (side by side, with a warning, where it
    # offers no stereo visual); side_by_side, top_bottom: frame packing for 3D projectors
    stereo: StereoMode = StereoMode.MONO
    # swap only when every swap-locked wall has drawn the frame (the swap barrier)
    swap_lock: bool = True


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _point(value: object) -> np.ndarray:
    p = np.array(value, dtype=np.float64)
    p.flags.writeable = False
    return p


@dataclass(frozen=True, eq=False)
class Wall:
    """One flat rectangular screen: three corners (m, read-only float64), its pixels and,
    optionally, the EGL device its node computes on."""

    name: str
    lower_left: np.ndarray
    lower_right: np.ndarray
    upper_left: np.ndarray
    resolution: tuple[int, int]  # (width_px, height_px)
    gpu: int | None = None  # EGL device index (None: `cavesim run` chooses)
    display: Display = field(default_factory=Display)  # how it is shown live
    node: str = ""  # the node that draws it ("": its own, named after the wall)

    def __post_init__(self) -> None:
        for key in ("lower_left", "lower_right", "upper_left"):
            p = _point(getattr(self, key))
            if p.shape != (3,) or not np.isfinite(p).all():
                raise ValueError(f"Wall {self.name!r}: {key} must be 3 finite numbers, "
                                 f"got {getattr(self, key)!r}")
            object.__setattr__(self, key, p)
        object.__setattr__(self, "resolution", tuple(int(n) for n in self.resolution))
        object.__setattr__(self, "node", self.node or self.name)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wall):
            return NotImplemented
        return (self.name == other.name and self.resolution == other.resolution
                and self.gpu == other.gpu and self.display == other.display
                and self.node == other.node
                and all(np.array_equal(getattr(self, k), getattr(other, k))
                        for k in ("lower_left", "lower_right", "upper_left")))

    def __hash__(self) -> int:
        return hash((self.name, self.resolution, self.gpu, self.corners.tobytes()))

    @property
    def upper_right(self) -> np.ndarray:
        return self.lower_right + self.upper_left - self.lower_left

    @property
    def right(self) -> np.ndarray:
        """Unit vector along the bottom edge, lower_left → lower_right."""
        return _unit(self.lower_right - self.lower_left)

    @property
    def up(self) -> np.ndarray:
        """Unit vector along the left edge, lower_left → upper_left."""
        return _unit(self.upper_left - self.lower_left)

    @property
    def normal(self) -> np.ndarray:
        """Unit `right × up`: from the screen toward the viewer inside the room."""
        return _unit(np.cross(self.right, self.up))

    @property
    def width(self) -> float:
        return float(np.linalg.norm(self.lower_right - self.lower_left))

    @property
    def height(self) -> float:
        return float(np.linalg.norm(self.upper_left - self.lower_left))

    @property
    def center(self) -> np.ndarray:
        return (self.lower_right + self.upper_left) / 2.0

    @property
    def corners(self) -> np.ndarray:
        """(4, 3) corners in the order lower_left, lower_right, upper_right, upper_left."""
        return np.stack([self.lower_left, self.lower_right, self.upper_right, self.upper_left])


@dataclass(frozen=True)
class Cave:
    """A named set of walls with unique names, in file order."""

    name: str
    walls: tuple[Wall, ...]
    eye_separation: float = DEFAULT_EYE_SEPARATION  # m, for stereo

    def __post_init__(self) -> None:
        object.__setattr__(self, "walls", tuple(self.walls))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(w.name for w in self.walls)

    @property
    def nodes(self) -> dict[str, tuple[str, ...]]:
        """Each node's walls, both in file order."""
        nodes: dict[str, tuple[str, ...]] = {}
        for w in self.walls:
            nodes[w.node] = (*nodes.get(w.node, ()), w.name)
        return nodes

    def wall(self, name: str) -> Wall:
        """The wall called `name` (KeyError naming the walls there are)."""
        for w in self.walls:
            if w.name == name:
                return w
        raise KeyError(f"cave {self.name!r} has no wall {name!r}; walls: {', '.join(self.names)}")

    def scaled(self, scale: float) -> Cave:
        """The CAVE with every wall's resolution times `scale`, kept within
        WALL_RESOLUTION_RANGE (its geometry unchanged)."""
        low, high = WALL_RESOLUTION_RANGE
        return replace(self, walls=tuple(
            replace(w, resolution=tuple(min(high, max(low, round(n * scale)))
                                        for n in w.resolution))
            for w in self.walls))


@dataclass(frozen=True, kw_only=True)
class WallTable:
    """One [[wall]] of a CAVE file as written; `parse_cave` makes it a `Wall`."""

    name: Name
    lower_left: Point
    lower_right: Point
    upper_left: Point
    upper_right: Point | None = None  # redundant: when given, it must close the rectangle
    resolution: Annotated[tuple[int, int], Range.within(WALL_RESOLUTION_RANGE),
                          Note("[width_px, height_px]")]
    gpu: Annotated[int, Range.within(GPU_RANGE),
                   Note("an EGL device index (`cavesim doctor` lists the devices)")] | None = None
    display: Display | None = None  # default: a window of the wall's resolution, mono
    node: Annotated[Name, Note("the node that draws it; walls naming one node share its "
                               "context and GPU")] | None = None


@dataclass(frozen=True)
class CaveFile:
    """The top level of a CAVE file."""

    name: Name | None = None  # default: the file's stem
    eye_separation: Annotated[float, Range(ge=0.0, le=0.1), Note("metres between the eyes")
                              ] = DEFAULT_EYE_SEPARATION
    wall: tuple[WallTable, ...] = ()  # at least one


def load_cave(path: str | Path) -> Cave:
    """Read and check the CAVE geometry file at `path` (see config/cave/*.toml)."""
    path = Path(path)
    return parse_cave(read_toml(path, CaveError, "cave file"), path)


def parse_cave(data: Mapping[str, Any], source: Path | None = None) -> Cave:
    """Check a cave given as the dict `tomllib` would produce; `source` names it in errors.

    The cave's name defaults to the stem of `source` ("cave" without one).
    """
    top = Table(Source.of(source, CaveError), "", data, CaveFile)
    name = top.get("name", default=source.stem if source is not None else "cave")
    tables = top.tables("wall")
    if not tables:
        raise top.source.fail("wall is missing: a cave needs at least one [[wall]] table")
    walls = tuple(_wall(t) for t in tables)
    unique_names(tables, (w.name for w in walls))
    _one_node_one_context(tables, walls)
    return Cave(name=name, walls=walls, eye_separation=top.get("eye_separation"))


def _one_node_one_context(tables: tuple[Table, ...], walls: tuple[Wall, ...]) -> None:
    """A node is named once: a node called after a wall is that wall's own; the walls of a
    node share its GPU."""
    names = {w.name: w for w in walls}
    first: dict[str, tuple[Table, Wall]] = {}
    for t, w in zip(tables, walls, strict=True):
        if w.node in names and names[w.node].node != w.node:
            raise t.bad("node", f"{w.node!r} is the name of a wall that another node "
                                f"({names[w.node].node!r}) draws; name the node otherwise")
        t0, w0 = first.setdefault(w.node, (t, w))
        if w.gpu != w0.gpu:
            raise t.bad("gpu", f"must be the gpu of every wall of node {w.node!r}: "
                               f"{t0.key} has {w0.gpu}, one node computes on one GPU")


def _wall(t: Table) -> Wall:
    """A [[wall]] that is a rectangle of non-zero area with square pixels."""
    w = t.build()
    ll, lr, ul = (_point(p) for p in (w.lower_left, w.lower_right, w.upper_left))
    bottom, left = lr - ll, ul - ll
    width, height = float(np.linalg.norm(bottom)), float(np.linalg.norm(left))
    for key, edge, length in (("lower_right", "bottom", width), ("upper_left", "left", height)):
        if length < MIN_EDGE_M:
            raise t.bad(key, f"the wall's {edge} edge from lower_left is {length:g} m long; it "
                             f"must be at least {MIN_EDGE_M:g} m (a wall needs an area)")
    cos = float(np.dot(bottom, left)) / (width * height)
    if abs(cos) > MAX_COS:
        raise t.bad("upper_left", f"the wall must be a rectangle, but its bottom and left edges "
                                  f"are not perpendicular (cos = {cos:.3g}; allowed |cos| <= "
                                  f"{MAX_COS:g})")
    implied = lr + ul - ll
    if w.upper_right is not None and np.linalg.norm(_point(w.upper_right) - implied) > CORNER_TOL_M:
        raise t.bad("upper_right", f"the wall must be a rectangle: upper_right must equal "
                                   f"lower_right + upper_left - lower_left = {implied.tolist()} "
                                   f"within {CORNER_TOL_M:g} m")
    px_aspect, m_aspect = w.resolution[0] / w.resolution[1], width / height
    if abs(px_aspect / m_aspect - 1.0) > ASPECT_TOL:
        raise t.bad("resolution", f"pixels must be square: width_px/height_px = {px_aspect:.4g} "
                                  f"but the wall is {width:g} m x {height:g} m (aspect "
                                  f"{m_aspect:.4g}); the two must agree within {ASPECT_TOL:.0%}")
    return Wall(name=w.name, lower_left=ll, lower_right=lr, upper_left=ul,
                resolution=w.resolution, gpu=w.gpu, display=w.display or Display(),
                node=w.node or "")
