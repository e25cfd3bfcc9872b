"""The CAVE's screens in room coordinates, and the TOML file that describes them.

A `Cave` is read once at start-up (`load_cave`) and handed to the renderer, which makes
one off-axis projection per `Wall` from the tracked head (`cavesim.cave.projection`).
Room coordinates are metres, z up, floor at z = 0. A wall is given by three corners
seen from inside the room: `lower_left`, `lower_right`, `upper_left`; its `normal` points
from the screen toward the viewer. A wall may name the EGL device (`gpu`) its node computes
on; `cavesim run` spreads the other walls over the machine's GPUs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cavesim._toml import read_toml
from cavesim.errors import CaveError
from cavesim.limits import GPU_RANGE, NAME_RE, WALL_RESOLUTION_RANGE

TOP_KEYS = ("name", "wall")
WALL_KEYS = ("name", "lower_left", "lower_right", "upper_left", "upper_right", "resolution",
             "gpu")
NAME_RULE = "must be 1-32 characters, each a letter, digit, '_' or '-'"
MIN_EDGE_M = 1e-6  # shorter edges make a wall of no area
MAX_COS = 1e-6  # |cos| of the angle between the bottom and left edges of a rectangle
CORNER_TOL_M = 1e-6  # how far a given upper_right may sit from the one the rectangle implies
ASPECT_TOL = 0.01  # pixels may be 1% away from square


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

    def __post_init__(self) -> None:
        for key in ("lower_left", "lower_right", "upper_left"):
            p = _point(getattr(self, key))
            if p.shape != (3,) or not np.isfinite(p).all():
                raise ValueError(f"Wall {self.name!r}: {key} must be 3 finite numbers, "
                                 f"got {getattr(self, key)!r}")
            object.__setattr__(self, key, p)
        object.__setattr__(self, "resolution", tuple(int(n) for n in self.resolution))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wall):
            return NotImplemented
        return (self.name == other.name and self.resolution == other.resolution
                and self.gpu == other.gpu
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

    def __post_init__(self) -> None:
        object.__setattr__(self, "walls", tuple(self.walls))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(w.name for w in self.walls)

    def wall(self, name: str) -> Wall:
        """The wall called `name` (KeyError naming the walls there are)."""
        for w in self.walls:
            if w.name == name:
                return w
        raise KeyError(f"cave {self.name!r} has no wall {name!r}; walls: {', '.join(self.names)}")


def load_cave(path: str | Path) -> Cave:
    """Read and check the CAVE geometry file at `path` (see config/cave/*.toml)."""
    path = Path(path)
    return parse_cave(read_toml(path, CaveError, "cave file"), path)


def parse_cave(data: Mapping[str, Any], source: Path | None = None) -> Cave:
    """Check a cave given as the dict `tomllib` would produce; `source` names it in errors.

    The cave's name defaults to the stem of `source` ("cave" without one).
    """
    src = str(source) if source is not None else "<dict>"
    if not isinstance(data, Mapping):
        raise _bad(src, "<top level>", data, "must be a table")
    _known_keys(src, "", data, TOP_KEYS)
    name = _name(src, "name", data.get("name", source.stem if source is not None else "cave"))
    raw_walls = data.get("wall", [])
    if not isinstance(raw_walls, list) or not all(isinstance(w, Mapping) for w in raw_walls):
        raise _bad(src, "wall", raw_walls, "must be an array of tables, written [[wall]]")
    if not raw_walls:
        raise CaveError(f"{src}: wall is missing: a cave needs at least one [[wall]] table")
    walls: list[Wall] = []
    first_use: dict[str, str] = {}
    for i, raw in enumerate(raw_walls):
        key = f"wall[{i}]"
        wall = _wall(src, key, raw)
        if wall.name in first_use:
            raise _bad(src, f"{key}.name", wall.name,
                       f"must be unique; {first_use[wall.name]}.name has it already")
        first_use[wall.name] = key
        walls.append(wall)
    return Cave(name=name, walls=tuple(walls))


def _bad(src: str, key: str, value: object, allowed: str) -> CaveError:
    return CaveError(f"{src}: {key} = {value!r} is not allowed: {allowed}")


def _known_keys(src: str, prefix: str, table: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    for k in table:
        if k not in allowed:
            raise _bad(src, f"{prefix}{k}", table[k],
                       f"unknown key; allowed keys here: {', '.join(allowed)}")


def _required(src: str, key: str, table: Mapping[str, Any], name: str, rule: str) -> Any:
    if name not in table:
        raise CaveError(f"{src}: {key}.{name} is missing: required, {rule}")
    return table[name]


def _name(src: str, key: str, value: object) -> str:
    if not isinstance(value, str) or not NAME_RE.fullmatch(value):
        raise _bad(src, key, value, NAME_RULE)
    return value


def _finite(v: object) -> bool:
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    try:
        return math.isfinite(float(v))
    except OverflowError:  # an int beyond float range
        return False


def _xyz(src: str, key: str, value: object) -> np.ndarray:
    rule = "must be a list of 3 finite numbers [x, y, z] in metres"
    if not isinstance(value, list) or len(value) != 3 or not all(map(_finite, value)):
        raise _bad(src, key, value, rule)
    return _point(value)


def _wall(src: str, key: str, raw: Mapping[str, Any]) -> Wall:
    _known_keys(src, f"{key}.", raw, WALL_KEYS)
    point_rule = "a list of 3 finite numbers [x, y, z] in metres"
    lo, hi = WALL_RESOLUTION_RANGE
    res_rule = f"a list of 2 integers [width_px, height_px], each >= {lo} and <= {hi}"
    name = _name(src, f"{key}.name", _required(src, key, raw, "name", NAME_RULE))
    ll, lr, ul = (_xyz(src, f"{key}.{k}", _required(src, key, raw, k, point_rule))
                  for k in ("lower_left", "lower_right", "upper_left"))
    res = _required(src, key, raw, "resolution", res_rule)
    if (not isinstance(res, list) or len(res) != 2
            or any(isinstance(n, bool) or not isinstance(n, int) or not lo <= n <= hi
                   for n in res)):
        raise _bad(src, f"{key}.resolution", res, "must be " + res_rule)

    bottom, left = lr - ll, ul - ll
    width, height = float(np.linalg.norm(bottom)), float(np.linalg.norm(left))
    for k, edge, length in (("lower_right", "bottom", width), ("upper_left", "left", height)):
        if length < MIN_EDGE_M:
            raise _bad(src, f"{key}.{k}", raw[k],
                       f"the wall's {edge} edge from lower_left is {length:g} m long; it must "
                       f"be at least {MIN_EDGE_M:g} m (a wall needs an area)")
    cos = float(np.dot(bottom, left)) / (width * height)
    if abs(cos) > MAX_COS:
        raise _bad(src, f"{key}.upper_left", raw["upper_left"],
                   f"the wall must be a rectangle, but its bottom and left edges are not "
                   f"perpendicular (cos = {cos:.3g}; allowed |cos| <= {MAX_COS:g})")
    if "upper_right" in raw:
        ur = _xyz(src, f"{key}.upper_right", raw["upper_right"])
        implied = lr + ul - ll
        if np.linalg.norm(ur - implied) > CORNER_TOL_M:
            raise _bad(src, f"{key}.upper_right", raw["upper_right"],
                       f"the wall must be a rectangle: upper_right must equal lower_right + "
                       f"upper_left - lower_left = {implied.tolist()} within {CORNER_TOL_M:g} m")
    px_aspect, m_aspect = res[0] / res[1], width / height
    if abs(px_aspect / m_aspect - 1.0) > ASPECT_TOL:
        raise _bad(src, f"{key}.resolution", res,
                   f"pixels must be square: width_px/height_px = {px_aspect:.4g} but the wall "
                   f"is {width:g} m x {height:g} m (aspect {m_aspect:.4g}); the two must agree "
                   f"within {ASPECT_TOL:.0%}")
    return Wall(name=name, lower_left=ll, lower_right=lr, upper_left=ul,
                resolution=(res[0], res[1]), gpu=_gpu(src, f"{key}.gpu", raw.get("gpu")))


def _gpu(src: str, key: str, value: object) -> int | None:
    lo, hi = GPU_RANGE
    if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                              or not lo <= value <= hi):
        raise _bad(src, key, value, f"must be an EGL device index, an integer >= {lo} and "
                                    f"<= {hi} (`cavesim doctor` lists the devices)")
    return value
