"""Rotations of the tracker bridge in plain numpy: frames named by signed axes, a yaw, the
check that DTrack's matrix is a rotation, and the quaternion (x, y, z, w) the wire carries."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

AXIS_NAMES = ("x", "-x", "y", "-y", "z", "-z")
IDENTITY_AXES = ("x", "y", "z")


def is_frame(axes: Sequence[str]) -> bool:
    """Whether `axes` names x, y and z once each, signed or not, as a rotation (no mirror)."""
    return (len(axes) == 3 and all(a in AXIS_NAMES for a in axes)
            and len({a[-1] for a in axes}) == 3 and np.linalg.det(axes_matrix(axes)) > 0)


def axes_matrix(axes: Sequence[str]) -> np.ndarray:
    """M with p_frame = M @ p_source for a frame whose x, y and z axes are the source's
    signed axes `axes`, e.g. ("x", "-z", "y"): one row per axis of the frame."""
    m = np.zeros((3, 3))
    for row, name in enumerate(axes):
        m[row, "xyz".index(name[-1])] = -1.0 if name.startswith("-") else 1.0
    return m


def yaw_matrix(degrees: float) -> np.ndarray:
    """A turn by `degrees` about z, counter-clockwise seen from above (z up)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def is_rotation(m: np.ndarray, tolerance: float) -> bool:
    """Whether `m` is orthonormal within `tolerance` (each entry of MᵀM − I) and turns, not
    mirrors."""
    return bool(np.abs(m.T @ m - np.eye(3)).max() <= tolerance and np.linalg.det(m) > 0)


def quaternion_of(m: np.ndarray) -> tuple[float, float, float, float]:
    """The unit quaternion (x, y, z, w), w >= 0, of the rotation matrix `m` (Shepperd's
    method: it divides by the largest of four candidates, so it stays exact near 180°)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = m.tolist()
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, s / 4)
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = (s / 4, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 >= m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m01 + m10) / s, s / 4, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, s / 4, (m10 - m01) / s)
    v = np.array(q) / math.hypot(*q)
    return tuple((-v if v[3] < 0 else v).tolist())
