"""The ground and the bounce in portable arithmetic: `ground_at` and `collide` of
shaders/include/collision.glsl and heightfield.glsl, operation by operation in float32.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.fields.heights import HeightGrid
from cavesim.core.portable.arithmetic import (
    f_dot,
    f_length,
    f_mix,
    f_mul,
    f_normalize,
    f_sub,
)
from cavesim.core.portable.builtins import first_node, glsl_clamp, nodes

ONE = np.float32(1.0)


def ground_at(collision, heights: HeightGrid | None,
              xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground height (N,) and unit upward normal (N, 3) under each point (N, 2)."""
    if heights is None:  # a plane
        normal = np.zeros((len(xy), 3), dtype=np.float32)
        normal[:, 2] = ONE
        return np.full(len(xy), np.float32(collision.height)), normal
    return height_at(heights, xy)


def height_at(grid: HeightGrid, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """heightfield.glsl's bilinear height and the normal of its gradient, flat outside."""
    box_min, scale = np.asarray(grid.box_min, np.float32), grid.index_scale
    res = np.asarray(grid.resolution)
    unclamped = f_mul(f_sub(xy, box_min), scale)
    f = glsl_clamp(unclamped, np.float32(0.0), (res - 1).astype(np.float32))
    inside = (f == unclamped).astype(np.float32)
    i0 = first_node(f, res)
    t = f_sub(f, i0.astype(np.float32))
    tx, ty = t[:, 0], t[:, 1]
    h00, h10, h01, h11 = nodes(grid.height, i0, ((0, 0), (1, 0), (0, 1), (1, 1)))
    height = f_mix(f_mix(h00, h10, tx), f_mix(h01, h11, tx), ty)
    slope_x = f_mix(f_sub(h10, h00), f_sub(h11, h01), ty)
    slope_y = f_mix(f_sub(h01, h00), f_sub(h11, h10), tx)
    dh_dx = f_mul(f_mul(slope_x, scale[0]), inside[:, 0])
    dh_dy = f_mul(f_mul(slope_y, scale[1]), inside[:, 1])
    normal = f_normalize(np.stack([-dh_dx, -dh_dy, np.ones_like(dh_dx)], axis=-1))
    return height, normal


def collide(p: np.ndarray, v: np.ndarray, collision, heights: HeightGrid | None
            ) -> tuple[np.ndarray, np.ndarray]:
    """Push particles below the ground back onto it; bounce those heading in (Kolb et al.)."""
    height, n = ground_at(collision, heights, p[:, :2])
    below = ~(p[:, 2] >= height)  # as the shader's early return reads: NaN counts as below
    p, v = p.copy(), v.copy()
    p[below, 2] = height[below]
    vn = f_dot(v[below], n[below])
    into = vn < 0
    bouncing = np.flatnonzero(below)[into]
    vb, vn, n = v[bouncing], vn[into, None], n[below][into]
    v_normal = f_mul(vn, n)
    v_tangent = f_sub(vb, v_normal)
    slow = f_length(vb) < np.float32(collision.friction_min_speed)
    keep = np.where(slow, ONE, f_sub(ONE, np.float32(collision.friction)))[:, None]
    v[bouncing] = f_sub(f_mul(keep, v_tangent), f_mul(np.float32(collision.resilience), v_normal))
    return p, v
