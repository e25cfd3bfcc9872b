"""Scene geometry as flat triangle arrays (position, normal, colour per vertex, float32).

The terrain is the same ground the particles collide with; the helicopter is a simple
procedural model whose rotor is a separate mesh so it can spin.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.heightfield import HeightGrid, sample_height

SAND = (0.76, 0.66, 0.47)
HULL = (0.30, 0.34, 0.28)
DARK = (0.12, 0.12, 0.13)
VERTEX_FORMAT = "3f 3f 3f"
VERTEX_NAMES = ("in_position", "in_normal", "in_color")

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
    shade = 0.92 + 0.08 * np.sin(0.7 * xy[:, 0]) * np.cos(0.5 * xy[:, 1])
    vertices = np.column_stack([xy, z, normals, np.outer(shade, SAND)])
    i = np.arange(cells)
    ll = (i[:, None] * (cells + 1) + i[None, :]).ravel()
    quads = np.stack([ll, ll + 1, ll + cells + 2, ll, ll + cells + 2, ll + cells + 1], axis=1)
    return vertices[quads.ravel()].astype(np.float32)


def helicopter_body() -> np.ndarray:
    """Fuselage, tail boom, fin, skids and mast; nose along +x, rotor hub at (0, 0, 1.3)."""
    parts = [
        box((0.0, 0.0, 0.0), (4.0, 1.5, 1.6), HULL),
        box((1.9, 0.0, 0.2), (0.6, 1.2, 1.0), DARK),  # cockpit glass
        box((-3.6, 0.0, 0.35), (3.6, 0.35, 0.35), HULL),
        box((-5.3, 0.0, 0.95), (0.6, 0.12, 1.2), HULL),
        box((0.0, 0.75, -1.15), (3.4, 0.12, 0.12), DARK),
        box((0.0, -0.75, -1.15), (3.4, 0.12, 0.12), DARK),
        box((0.0, 0.0, 1.05), (0.25, 0.25, 0.5), DARK),
    ]
    return np.concatenate(parts)


def rotor(radius: float, blades: int = 4) -> np.ndarray:
    """The main rotor in its own frame (hub at the origin, spinning about z)."""
    parts = []
    for k in range(blades):
        angle = 2 * np.pi * k / blades
        blade = box((radius / 2, 0.0, 0.0), (radius, 0.35, 0.06), DARK)
        c, s = np.cos(angle), np.sin(angle)
        rotation = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float32)
        blade[:, 0:3] = blade[:, 0:3] @ rotation.T
        blade[:, 3:6] = blade[:, 3:6] @ rotation.T
        parts.append(blade)
    return np.concatenate(parts)
