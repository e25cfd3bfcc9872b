"""Ground collision (twin of `collide` in shaders/include/collision.glsl). `collision` is the
scene's [collision] table (cavesim.core.features.collision); `heights` its height field,
None for a plane."""

from __future__ import annotations

import numpy as np

from cavesim.core.fields.heights import HeightGrid, sample_height


def ground(collision, heights: HeightGrid | None, xy: np.ndarray,
           dtype) -> tuple[np.ndarray, np.ndarray]:
    """Ground height (N,) and unit upward normal (N, 3) under each point."""
    if heights is None:  # a plane
        normal = np.zeros((len(xy), 3), dtype=dtype)
        normal[:, 2] = 1
        return np.full(len(xy), collision.height, dtype=dtype), normal
    return sample_height(heights, xy, dtype=dtype)


def collide(p: np.ndarray, v: np.ndarray, collision, heights: HeightGrid | None
            ) -> tuple[np.ndarray, np.ndarray]:
    """Push particles below the ground back onto it; bounce those heading in (Kolb et al.).

    v' = (1 - nu) v_t - epsilon v_n, with no friction below `friction_min_speed`.
    """
    height, normal = ground(collision, heights, p[:, :2], p.dtype)
    below = p[:, 2] < height
    p, v = p.copy(), v.copy()
    p[below, 2] = height[below]
    vn = np.einsum("ij,ij->i", v, normal)
    bounce = below & (vn < 0)
    v_normal = vn[bounce, None] * normal[bounce]
    v_tangent = v[bounce] - v_normal
    slow = np.linalg.norm(v[bounce], axis=1) < collision.friction_min_speed
    keep = np.where(slow, 1.0, 1.0 - collision.friction)[:, None]
    v[bounce] = keep * v_tangent - collision.resilience * v_normal
    return p, v
