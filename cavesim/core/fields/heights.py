"""The ground as a height field: the surface particles collide with and the walls draw.

Data flow: a scene's `Collision` of kind HEIGHTFIELD names an .npz file; `load_heightfield`
checks it at the door and gives a `HeightGrid`; the GL engine uploads
`grid.height.tobytes()` as a 1-component 2D texture that the collision stage samples every
frame. `sample_height` is the numpy twin of that lookup (height and surface normal).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.fields.npz_archive import read_npz
from cavesim.core.fields.regular_grid import (
    cells,
    check_box,
    corner_of,
    float_grid,
    index_scale,
    mix,
)

MAX_HEIGHT_NODES = 4096  # per axis, a common GL_MAX_TEXTURE_SIZE floor


@dataclass(frozen=True, eq=False)
class HeightGrid:
    """Ground height z (m) at the nodes of a regular grid whose corner nodes are the box corners.

    `height[j, i]` is the height at (x, y) = box_min + (i, j) · (box_max − box_min) / (res − 1).
    It is stored float32, C-contiguous and read-only, so `height.tobytes()` is the data of a 2D
    texture of size (nx, ny) with 1 component.
    """

    height: np.ndarray  # (ny, nx)
    box_min: tuple[float, float]
    box_max: tuple[float, float]

    def __post_init__(self) -> None:
        height = np.ascontiguousarray(self.height, dtype=np.float32).view()
        if height.ndim != 2 or min(height.shape) < 2:
            raise FieldError(f"height grid has shape {height.shape}, expected (ny, nx) with at "
                             "least 2 nodes per axis")
        height.flags.writeable = False
        box_min, box_max = check_box(self.box_min, self.box_max, 2, "height field")
        object.__setattr__(self, "height", height)
        object.__setattr__(self, "box_min", box_min)
        object.__setattr__(self, "box_max", box_max)

    @property
    def resolution(self) -> tuple[int, int]:
        """Nodes per axis as (nx, ny)."""
        ny, nx = self.height.shape
        return nx, ny

    @property
    def index_scale(self) -> np.ndarray:
        """Grid index per metre on each axis, float32: the shader's uniform of this name."""
        return index_scale(self.box_min, self.box_max, self.resolution)


def load_heightfield(path, origin=None) -> HeightGrid:
    """Read an .npz with "height" (ny, nx) of floats and "box_min", "box_max" (x, y) each,
    in world coordinates, relative to the scene's `origin` (None: the world's; see
    cavesim.core.scene.origin)."""
    path = Path(path)
    arrays = read_npz(path, {"height": MAX_HEIGHT_NODES**2, "box_min": 2, "box_max": 2})
    height = float_grid(path, "height", arrays["height"], "(ny, nx)", MAX_HEIGHT_NODES)
    origin = origin or (0.0, 0.0, 0.0)
    if origin[2]:
        height = (height.astype(np.float64) - origin[2]).astype(np.float32)
    box_min, box_max = (tuple(c - o for c, o in zip(corner_of(path, name, arrays[name], 2),
                                                    origin[:2], strict=True))
                        for name in ("box_min", "box_max"))
    if not all(a < b for a, b in zip(box_min, box_max, strict=True)):
        raise FieldError(f"{path}: arrays 'box_min' = {box_min} and 'box_max' = {box_max}, "
                         "expected box_max > box_min on both axes")
    return HeightGrid(height, box_min, box_max)


def save_heightfield(path, grid: HeightGrid) -> None:
    """Write `grid` as an .npz with "height" (ny, nx), "box_min" and "box_max"."""
    with open(path, "wb") as file:  # an open file keeps np.savez from appending ".npz"
        np.savez(file, height=grid.height, box_min=np.asarray(grid.box_min),
                 box_max=np.asarray(grid.box_max))


def sample_height(grid: HeightGrid, xy, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear ground height (...,) and unit upward normal (..., 3) at points xy (..., 2).

    Everything is computed in `dtype`; box corners and points are rounded to it first. Per
    axis, with res the nodes on it (as in fields.sample_field):
      f  = (p − box_min) / (box_max − box_min) · (res − 1)   (left to right)
      fc = clamp(f, 0, res − 1),  i0 = min(floor(fc), res − 2),  t = fc − i0
    With mix(a, b, t) = a·(1 − t) + b·t and h_yx = height[i0y+y, i0x+x]:
      h     = mix(mix(h00, h01, tx), mix(h10, h11, tx), ty)
      dh/dx = mix(h01 − h00, h11 − h10, ty) · ((res_x − 1) / (box_max_x − box_min_x))
      dh/dy = mix(h10 − h00, h11 − h01, tx) · ((res_y − 1) / (box_max_y − box_min_y))
    where each derivative is set to 0 on an axis where f was clamped (outside the box the edge
    height continues, flat along that axis). On a node the gradient is that of the cell from
    i0 (the cell above it, or the last cell). normal = normalize(−dh/dx, −dh/dy, 1).
    A point with a NaN coordinate gives NaN height and normal.
    """
    p = np.asarray(xy, dtype=dtype)
    if p.shape[-1:] != (2,):
        raise ValueError(f"xy must have shape (..., 2), got {p.shape}")
    flat = p.reshape(-1, 2)
    lo, hi = np.asarray(grid.box_min, dtype), np.asarray(grid.box_max, dtype)
    res = grid.resolution
    i0, t, f = cells(flat, lo, hi, res, dtype)
    (ix, iy), (tx, ty) = i0.T, t.T
    heights = grid.height

    def node(dy: int, dx: int) -> np.ndarray:
        return heights[iy + dy, ix + dx].astype(dtype)

    h00, h01, h10, h11 = node(0, 0), node(0, 1), node(1, 0), node(1, 1)
    height = mix(mix(h00, h01, tx), mix(h10, h11, tx), ty)
    per_metre = (np.asarray(res, dtype) - 1) / (hi - lo)
    inside = (f >= 0) & (f <= np.asarray(res, dtype) - 1)
    dh_dx = np.where(inside[:, 0], mix(h01 - h00, h11 - h10, ty) * per_metre[0], 0)
    dh_dy = np.where(inside[:, 1], mix(h10 - h00, h11 - h01, tx) * per_metre[1], 0)
    normal = np.stack([-dh_dx, -dh_dy, np.ones_like(dh_dx)], axis=-1)
    normal /= np.sqrt(dh_dx * dh_dx + dh_dy * dh_dy + 1)[:, None]
    lost = np.isnan(flat).any(axis=1)
    height[lost], normal[lost] = np.nan, np.nan
    return height.reshape(p.shape[:-1]), normal.reshape((*p.shape[:-1], 3))
