"""Scene geometry as flat triangle arrays (position, normal, colour per vertex, float32).

The terrain is the same ground the particles collide with; its sand pattern is drawn by
the scene shader from world position. The built-in helicopter is built from swept tubes and
plates in its model frame (nose along +x, rotor hub at (0, 0, MESH_HUB_HEIGHT)); a scene may
name a glTF file instead (`gltf_model.py`). Its main and tail rotors are one disc mesh, spun
by the pose's rotor matrices and drawn translucent with blurred blades.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.fields.heights import HeightGrid, sample_height
from cavesim.core.scene_frame import MESH_HUB_HEIGHT

SAND = (0.76, 0.66, 0.47)
HULL = (0.30, 0.34, 0.28)
DARK = (0.12, 0.12, 0.13)
GLASS = (0.10, 0.16, 0.22)
VERTEX_FORMAT = "3f 3f 3f"
VERTEX_NAMES = ("in_position", "in_normal", "in_color")
TAIL_ROTOR_BLADES = 2  # of every model's tail rotor disc (the main rotor's: RenderSettings)

_CUBE_FACES = (  # normal, then two tangent axes spanning the face
    ((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
)


def box(center, size, color) -> np.ndarray:
    """An axis-aligned box as 12 triangles: (36, 9) rows of position, normal, colour."""
    center, half = np.asarray(center, float), np.asarray(size, float) / 2
    rows = []
    for normal, u, v in _CUBE_FACES:
        n, u, v = (np.asarray(a, float) for a in (normal, u, v))
        corners = [center + half * (n + su * u + sv * v)
                   for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        for index in (0, 1, 2, 0, 2, 3):
            rows.append([*corners[index], *n, *color])
    return np.array(rows, dtype=np.float32)


def terrain(box_min, box_max, height: float | HeightGrid, cells: int = 96) -> np.ndarray:
    """The ground over the xy box as a lit triangle grid: a plane height or a height field."""
    xs = np.linspace(box_min[0], box_max[0], cells + 1)
    ys = np.linspace(box_min[1], box_max[1], cells + 1)
    gx, gy = np.meshgrid(xs, ys)
    xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
    if isinstance(height, HeightGrid):
        z, normals = sample_height(height, xy)
    else:
        z, normals = np.full(len(xy), float(height)), np.tile([0.0, 0.0, 1.0], (len(xy), 1))
    patches = 0.6 * value_noise(xy * 0.13) + 0.4 * value_noise(xy * 0.7)
    vertices = np.column_stack([xy, z, normals, np.outer(0.84 + 0.2 * patches, SAND)])
    i = np.arange(cells)
    ll = (i[:, None] * (cells + 1) + i[None, :]).ravel()
    quads = np.stack([ll, ll + 1, ll + cells + 2, ll, ll + cells + 2, ll + cells + 1], axis=1)
    return vertices[quads.ravel()].astype(np.float32)


def value_noise(p: np.ndarray) -> np.ndarray:
    """Smooth noise in [0, 1) over (N, 2) points, from hashed values on the integer grid."""
    cell = np.floor(p)
    f = p - cell
    u = f * f * (3.0 - 2.0 * f)
    i = cell.astype(np.int64)

    def at(dx: int, dy: int) -> np.ndarray:
        h = ((i[:, 0] + dx) * 73856093 ^ (i[:, 1] + dy) * 19349663) & 0xFFFFFFFF
        h = (h ^ (h >> 13)) * 1274126177 & 0xFFFFFFFF
        return ((h ^ (h >> 16)) & 0xFFFFFF) / 16777216.0

    low = at(0, 0) + u[:, 0] * (at(1, 0) - at(0, 0))
    high = at(0, 1) + u[:, 0] * (at(1, 1) - at(0, 1))
    return low + u[:, 1] * (high - low)


def sweep(path, radii, color, segments: int = 16, caps: bool = True) -> np.ndarray:
    """A tube of elliptic cross-sections along a polyline: `path` (K, 3) centres, `radii`
    (K, 2) half-widths (sideways, upward); `color` one RGB or a function of a triangle's
    centroid. Normals are smooth and point outward; open ends are closed by flat caps."""
    path, radii = np.asarray(path, float), np.asarray(radii, float)
    tangent = np.gradient(path, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    reference = np.where(np.abs(tangent[:, 2:3]) > 0.9, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    side = np.cross(tangent, reference)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    up = np.cross(side, tangent)
    angle = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring = (np.cos(angle)[None, :, None] * (radii[:, 0:1] * side)[:, None, :]
            + np.sin(angle)[None, :, None] * (radii[:, 1:2] * up)[:, None, :])
    grid = path[:, None, :] + ring  # (K, segments, 3)
    around = np.roll(grid, -1, axis=1) - np.roll(grid, 1, axis=1)
    along = np.gradient(grid, axis=0)
    normals = np.cross(along, around)
    normals *= np.sign(np.einsum("kjc,kjc->kj", normals, ring))[..., None]
    length = np.linalg.norm(normals, axis=2, keepdims=True)
    fallback = ring / np.maximum(np.linalg.norm(ring, axis=2, keepdims=True), 1e-9)
    normals = np.where(length > 1e-9, normals / np.maximum(length, 1e-9), fallback)
    k, j = np.meshgrid(np.arange(len(path) - 1), np.arange(segments), indexing="ij")
    k, j = k.ravel(), j.ravel()
    jn = (j + 1) % segments
    order = [(k, j), (k + 1, j), (k + 1, jn), (k, j), (k + 1, jn), (k, jn)]
    triangles = [np.concatenate([grid[ck, cj], normals[ck, cj]], axis=-1) for ck, cj in order]
    rows = np.stack(triangles, axis=1).reshape(-1, 6)
    if caps:
        rows = np.concatenate([rows, *(_cap(grid[e], path[e], sign * tangent[e])
                                      for e, sign in ((0, -1.0), (-1, 1.0)))])
    return _paint(rows, color)


def _cap(ring: np.ndarray, centre: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """A flat fan closing one end of a tube: (3 * len(ring), 6) rows."""
    following = np.roll(ring, -1, axis=0)
    points = np.stack([np.broadcast_to(centre, ring.shape), ring, following], axis=1)
    return np.concatenate([points, np.broadcast_to(normal, points.shape)], axis=-1).reshape(-1, 6)


def _paint(rows: np.ndarray, color) -> np.ndarray:
    """Rows of position and normal, with one colour or a colour per triangle's centroid."""
    if callable(color):
        centroids = rows[:, :3].reshape(-1, 3, 3).mean(axis=1)
        colors = np.repeat(np.array([color(c) for c in centroids], float), 3, axis=0)
    else:
        colors = np.tile(color, (len(rows), 1))
    return np.column_stack([rows, colors]).astype(np.float32)


def plate(outline, thickness: float, color) -> np.ndarray:
    """A flat plate in the xz plane (y = 0): a convex `outline` of (x, z) points, extruded
    `thickness` across y."""
    outline = np.asarray(outline, float)
    half = thickness / 2
    rows = []
    for sign in (1.0, -1.0):
        for a, b in zip(outline[1:-1], outline[2:], strict=True):
            for x, z in (outline[0], a, b):
                rows.append([x, sign * half, z, 0.0, sign, 0.0])
    for (x0, z0), (x1, z1) in zip(outline, np.roll(outline, -1, axis=0), strict=True):
        edge = np.array([z1 - z0, 0.0, -(x1 - x0)])
        n = edge / np.linalg.norm(edge)
        n *= np.sign(n[[0, 2]] @ ([x0, z0] - outline.mean(axis=0))) or 1.0
        quad = [(x0, -half, z0), (x1, -half, z1), (x1, half, z1), (x0, half, z0)]
        rows += [[*quad[i], *n] for i in (0, 1, 2, 0, 2, 3)]
    return _paint(np.array(rows), color)


def _fuselage_color(centroid) -> tuple[float, float, float]:
    """Cockpit glass over the front upper half of the cabin, hull elsewhere."""
    x, _, z = centroid
    return GLASS if x > 0.9 and z > 0.05 - 0.35 * (x - 0.9) else HULL


# The body is laid out in design units with the hub at (0, 0, 1.3) and the skids' soles
# 2.5 below it, then fitted: soles at z = 0 and a fuselage as long as a rotor diameter of
# a typical scene's helicopter (brownout: 7.3 m rotor radius at 3 m hub height).
_DESIGN_HUB = np.array([0.0, 0.0, 1.3])
_DESIGN_SCALE = np.array([0.68, MESH_HUB_HEIGHT / 2.5, MESH_HUB_HEIGHT / 2.5])
# The tail rotor beside the fin's left side; its radius is fitted by the height's scale, so
# the disc clears the boom as designed.
_DESIGN_TAIL_HUB = np.array([-5.80, 0.16, 1.25])
_DESIGN_TAIL_RADIUS = 0.62


@dataclass(frozen=True)
class TailRotor:
    """Where a helicopter's tail rotor disc turns (about the model's y): model frame."""

    hub: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class HelicopterModel:
    """A helicopter as the walls draw it: its body as rows in the model frame (nose along
    +x, the skids' soles at z = 0, the rotor hub at (0, 0, MESH_HUB_HEIGHT)) and its tail
    rotor, if it has one."""

    body: np.ndarray
    tail_rotor: TailRotor | None


def built_in_helicopter() -> HelicopterModel:
    """The helicopter of a scene that names no model file."""
    hub = tuple(_fitted(_DESIGN_TAIL_HUB).tolist())
    return HelicopterModel(_body(), TailRotor(hub, float(_DESIGN_TAIL_RADIUS * _DESIGN_SCALE[2])))


def _fitted(points: np.ndarray) -> np.ndarray:
    """Design units to the model frame."""
    return (points - _DESIGN_HUB) * _DESIGN_SCALE + [0.0, 0.0, MESH_HUB_HEIGHT]


def _body() -> np.ndarray:
    """Fuselage with cockpit glass, engine cowling, mast, tail boom, fin with the tail
    rotor's shaft, stabilizer, and two skids on struts; nose along +x, the skids' soles at
    z = 0 (the pose's position), the rotor hub at (0, 0, MESH_HUB_HEIGHT)."""
    # stations nose to tail: x, centre height, half-width, half-height
    cabin = np.array([
        (2.55, -0.10, 0.05, 0.05), (2.45, -0.12, 0.38, 0.40), (2.20, -0.10, 0.62, 0.66),
        (1.70, -0.04, 0.76, 0.80), (0.80, 0.00, 0.80, 0.84), (-0.40, 0.02, 0.78, 0.82),
        (-1.30, 0.10, 0.66, 0.70), (-2.00, 0.28, 0.42, 0.45), (-2.50, 0.40, 0.24, 0.26),
    ])
    boom = np.array([(-2.40, 0.40, 0.22, 0.24), (-4.00, 0.48, 0.16, 0.17),
                     (-5.55, 0.55, 0.11, 0.12)])
    cowling = np.array([(0.90, 0.80, 0.05, 0.03), (0.70, 0.86, 0.36, 0.20),
                        (-0.60, 0.88, 0.40, 0.24), (-1.40, 0.74, 0.26, 0.16),
                        (-1.60, 0.70, 0.05, 0.03)])
    parts = [sweep(p[:, [0, 0, 1]] * [1, 0, 1], p[:, 2:4], color, segments)
             for p, color, segments in ((cabin, _fuselage_color, 24), (boom, HULL, 12),
                                        (cowling, HULL, 16))]
    mast = [(0.0, 0.0, 0.95), (0.0, 0.0, MESH_HUB_HEIGHT + 0.08)]
    parts.append(sweep(mast, [(0.09, 0.09)] * 2, DARK, 8))
    fin = plate([(-4.95, 0.50), (-5.70, 0.45), (-6.05, 1.75), (-5.70, 1.80)], 0.08, HULL)
    parts.append(fin)
    parts.append(box((-4.60, 0.0, 0.50), (0.45, 1.50, 0.05), HULL))  # stabilizer
    hub = _DESIGN_TAIL_HUB  # the tail rotor's shaft, out of the fin and through its disc
    parts.append(sweep([hub * [1, 0, 1], hub + [0, 0.06, 0]], [(0.08, 0.08)] * 2, DARK, 8))
    for side in (1.0, -1.0):
        y = 0.85 * side
        skid = [(-1.55, y, -1.14), (1.40, y, -1.14), (1.72, y, -1.08), (1.92, y, -0.92)]
        # soles at -1.2
        parts.append(sweep(skid, [(0.06, 0.06)] * 4, DARK, 8))
        for x in (-0.85, 0.95):
            parts.append(sweep([(x, y, -1.14), (x, 0.52 * side, -0.55)], [(0.05, 0.05)] * 2,
                               DARK, 8))
    body = np.concatenate(parts)
    body[:, 0:3] = _fitted(body[:, 0:3])
    normals = body[:, 3:6] / _DESIGN_SCALE  # the inverse transpose of the scaling
    body[:, 3:6] = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    return body


def rotor(radius: float, rings: int = 8, segments: int = 96) -> np.ndarray:
    """The rotor disc in its own frame (hub at the origin, spinning about z, blade 0 along
    +x): the scene shader makes it translucent, opaque only along blurred blades."""
    r = np.linspace(0.0, radius, rings + 1)
    a = np.linspace(0.0, 2 * np.pi, segments + 1)
    grid = np.stack(np.meshgrid(r, a, indexing="ij"), axis=-1)  # (rings+1, segments+1, 2)
    points = np.stack([grid[..., 0] * np.cos(grid[..., 1]),
                       grid[..., 0] * np.sin(grid[..., 1]), np.zeros(grid.shape[:2])], -1)
    k, j = (m.ravel() for m in np.meshgrid(np.arange(rings), np.arange(segments),
                                           indexing="ij"))
    order = [(k, j), (k + 1, j), (k + 1, j + 1), (k, j), (k + 1, j + 1), (k, j + 1)]
    corners = np.stack([points[ck, cj] for ck, cj in order], axis=1).reshape(-1, 3)
    return _paint(np.column_stack([corners, np.tile([0.0, 0.0, 1.0], (len(corners), 1))]),
                  DARK)
