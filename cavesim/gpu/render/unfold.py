"""Unfolding a CAVE flat: where each wall's picture goes in the composite, from geometry.

Walls that share an edge are folded flat across it, outward from the wall that faces the
viewer; see `unfold_layout`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from cavesim.core.cave.geometry import Cave, Wall

log = logging.getLogger(__name__)

# Walls of a config file meet to the millimetre; closer than this counts as the same point.
EDGE_TOL_M = 1e-3
VIEWER_FACING = np.array([0.0, -1.0, 0.0])  # the front wall's normal: the viewer faces +y


@dataclass(frozen=True)
class _Flat:
    """A wall laid flat: composite metres (x right, y down) of wall point (a, b) along
    (right, up) are `origin + a * r + b * u`; `turns` counter-clockwise quarter turns."""

    origin: np.ndarray
    turns: int
    width: float
    height: float

    @property
    def r(self) -> np.ndarray:
        return _turn(np.array([1.0, 0.0]), self.turns)

    @property
    def u(self) -> np.ndarray:
        return _turn(np.array([0.0, -1.0]), self.turns)

    def at(self, a: float, b: float) -> np.ndarray:
        return self.origin + a * self.r + b * self.u

    def box(self) -> np.ndarray:
        """[[x_min, y_min], [x_max, y_max]] in composite metres."""
        corners = np.array([self.at(a, b) for a in (0, self.width) for b in (0, self.height)])
        return np.array([corners.min(axis=0), corners.max(axis=0)])


def _turn(v: np.ndarray, turns: int) -> np.ndarray:
    for _ in range(turns % 4):
        v = np.array([v[1], -v[0]])  # a counter-clockwise quarter turn on a y-down screen
    return v


def _local(wall: Wall, p: np.ndarray) -> tuple[float, float]:
    d = p - wall.lower_left
    return float(d @ wall.right), float(d @ wall.up)


def _shared_edge(w1: Wall, w2: Wall) -> tuple[np.ndarray, np.ndarray] | None:
    """The segment (room metres) along which an edge of `w1` and one of `w2` coincide."""
    c1, c2 = w1.corners, w2.corners
    for i in range(4):
        p, q = c1[i], c1[(i + 1) % 4]
        length = float(np.linalg.norm(q - p))
        d = (q - p) / length
        for j in range(4):
            ends = np.array([c2[j], c2[(j + 1) % 4]]) - p
            along = ends @ d
            if np.linalg.norm(ends - np.outer(along, d), axis=1).max() > EDGE_TOL_M:
                continue  # not on the line of this edge
            lo, hi = max(0.0, along.min()), min(length, along.max())
            if hi - lo > EDGE_TOL_M:
                return p + lo * d, p + hi * d
    return None


def _unfold(placed: _Flat, placed_wall: Wall, wall: Wall,
            edge: tuple[np.ndarray, np.ndarray]) -> _Flat | None:
    """`wall` laid flat beside `placed` so that their shared `edge` lands on the same line,
    or None when no quarter turn does that with the two walls on opposite sides."""
    target = [placed.at(*_local(placed_wall, p)) for p in edge]
    along = target[1] - target[0]

    def side(point: np.ndarray) -> float:
        d = point - target[0]
        return float(along[0] * d[1] - along[1] * d[0])

    for turns in range(4):
        flat = _Flat(np.zeros(2), turns, wall.width, wall.height)
        flat = _Flat(target[0] - flat.at(*_local(wall, edge[0])), turns, wall.width, wall.height)
        if np.linalg.norm(flat.at(*_local(wall, edge[1])) - target[1]) > EDGE_TOL_M:
            continue
        mid = flat.at(wall.width / 2, wall.height / 2)
        if side(mid) * side(placed.at(placed.width / 2, placed.height / 2)) < 0:
            return flat
    return None


def _overlaps(box: np.ndarray, others: list[np.ndarray]) -> bool:
    return any(((np.minimum(box[1], o[1]) - np.maximum(box[0], o[0])) > EDGE_TOL_M).all()
               for o in others)


def _front(cave: Cave) -> Wall:
    if not cave.walls:
        raise ValueError(f"cave {cave.name!r} has no walls to lay out")
    return max(cave.walls, key=lambda w: float(w.normal @ VIEWER_FACING))


def _lay_flat(cave: Cave) -> dict[str, _Flat]:
    front = _front(cave)
    flats = {front.name: _Flat(np.array([0.0, front.height]), 0, front.width, front.height)}
    depth = {front.name: 0}
    edges = {(a.name, b.name): _shared_edge(a, b)
             for a in cave.walls for b in cave.walls if a is not b}
    while len(flats) < len(cave.walls):
        options = []
        boxes = [f.box() for f in flats.values()]
        for order, wall in enumerate(cave.walls):
            if wall.name in flats:
                continue
            for name, flat in flats.items():
                edge = edges[name, wall.name]
                if edge is None:
                    continue
                new = _unfold(flat, cave.wall(name), wall, edge)
                if new is None or _overlaps(new.box(), boxes):
                    continue
                ends = [flat.at(*_local(cave.wall(name), p)) for p in edge]
                beside = abs(ends[0][0] - ends[1][0]) < EDGE_TOL_M  # joined across a vertical
                centre_x = new.at(wall.width / 2, wall.height / 2)[0]
                options.append(((depth[name], not beside, -centre_x, order), wall, new, name))
        if not options:
            break
        _, wall, new, parent = min(options, key=lambda o: o[0])
        flats[wall.name], depth[wall.name] = new, depth[parent] + 1
    loose = [w for w in cave.walls if w.name not in flats]
    if loose:
        log.warning("cave %r: walls %s share no edge with the unfolded walls; they are "
                    "placed in a row to the right", cave.name, ", ".join(w.name for w in loose))
        x = max(f.box()[1][0] for f in flats.values())
        y = min(f.box()[0][1] for f in flats.values())
        for w in loose:
            flats[w.name] = _Flat(np.array([x, y + w.height]), 0, w.width, w.height)
            x += w.width
    return flats


@dataclass(frozen=True)
class Slot:
    x: int
    y: int
    turns: int
    size: tuple[int, int]  # the wall picture's (width_px, height_px) before turning

    @property
    def turned_size(self) -> tuple[int, int]:
        return self.size[::-1] if self.turns % 2 else self.size


def slots_of(cave: Cave) -> tuple[dict[str, Slot], tuple[int, int]]:
    front = _front(cave)
    ppm = front.resolution[0] / front.width
    flats = _lay_flat(cave)
    low = np.min([f.box()[0] for f in flats.values()], axis=0)
    slots = {}
    for w in cave.walls:
        flat = flats[w.name]
        x, y = np.rint((flat.box()[0] - low) * ppm).astype(int)
        size = (max(1, round(w.width * ppm)), max(1, round(w.height * ppm)))
        slots[w.name] = Slot(int(x), int(y), flat.turns, size)
    width = max(s.x + s.turned_size[0] for s in slots.values())
    height = max(s.y + s.turned_size[1] for s in slots.values())
    return slots, (width, height)


def unfold_layout(cave: Cave) -> dict[str, tuple[int, int, int]]:
    """Where each wall's picture goes in the unfolded-CAVE composite.

    Returns `{wall name: (x_px, y_px, quarter_turns)}`: the top-left pixel of the wall's
    picture after it has been turned `quarter_turns` times counter-clockwise (as
    `PIL.Image.Transpose.ROTATE_90` and `np.rot90` turn).

    The layout follows from the geometry alone, never from wall names:

    1. The front is the wall whose normal is closest to -y (it faces the viewer). It lies
       flat unturned, and sets the scale: its pixels per metre, `resolution[0] / width`;
       every wall is drawn at `round(width * ppm) x round(height * ppm)` pixels.
    2. Two walls are neighbours when an edge of one lies along an edge of the other
       (a common segment longer than `EDGE_TOL_M`).
    3. Breadth first from the front, an unplaced neighbour of a placed wall is folded
       flat across their shared edge: the quarter turn is chosen that puts both ends of
       the edge where the placed wall has them, with the two walls on opposite sides. A
       wall reached from several placed walls (the back of a six-sided CAVE touches
       four) is attached, in this order of preference, to the one nearest the front,
       across a vertical edge (keeps the walls around the viewer in one row), to the
       right. A fold that would overlap a placed wall is not taken.
    4. Walls that share no edge with the unfolded ones go in a row to the right, unturned
       (with a warning). The composite is the bounding box of all walls, so the result
       for the FLEX CAVE is a T (left, front, right above floor), for a six-sided CAVE a
       cross with the back beyond the right wall, and a single wall is just itself.
    """
    slots, _ = slots_of(cave)
    return {name: (s.x, s.y, s.turns) for name, s in slots.items()}
