"""Head-tracked off-axis projection for one CAVE wall, in plain numpy (no GL).

Each frame the renderer takes the tracked head, turns it into eye positions
(`eye_positions`), and for every wall draws the scene with `off_axis(wall, eye)` — Kooima,
"Generalized Perspective Projection" (2008). Matrices follow OpenGL with column vectors:
`clip = P @ V @ [x, y, z, 1]` for a room point. Because every wall's frustum passes through
that wall's exact corners, the images of neighbouring walls meet without a seam.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.cave.geometry import Wall

MIN_EYE_DISTANCE_M = 1e-6  # closer to (or behind) the wall plane there is no frustum


def _vec3(name: str, value: object) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be 3 finite numbers (x, y, z) in metres, got {value!r}")
    return v


def frustum(left: float, right: float, bottom: float, top: float, near: float,
            far: float) -> np.ndarray:
    """The 4×4 float64 matrix `glFrustum(left, right, bottom, top, near, far)` builds."""
    w, h, d = right - left, top - bottom, far - near
    return np.array([
        [2 * near / w, 0.0, (right + left) / w, 0.0],
        [0.0, 2 * near / h, (top + bottom) / h, 0.0],
        [0.0, 0.0, -(far + near) / d, -2 * far * near / d],
        [0.0, 0.0, -1.0, 0.0],
    ])


def off_axis(wall: Wall, eye: object, near: float = 0.05,
             far: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    """(P, V): the projection and view matrices that show the room on `wall` from `eye`.

    V rotates room axes onto the wall's (right, up, normal) and moves `eye` to the origin;
    P is the asymmetric frustum through the wall's corners, cut at `near` and `far` (m).
    """
    pe = _vec3("eye", eye)
    if not (np.isfinite(near) and np.isfinite(far) and 0 < near < far):
        raise ValueError(f"near and far must be finite with 0 < near < far, got {near=!r}, "
                         f"{far=!r}")
    vr, vu, vn = wall.right, wall.up, wall.normal
    va, vb, vc = wall.lower_left - pe, wall.lower_right - pe, wall.upper_left - pe
    d = -float(np.dot(va, vn))  # eye's distance in front of the wall plane (Kooima eq. 13)
    if d <= MIN_EYE_DISTANCE_M:
        raise ValueError(f"eye = {pe.tolist()} is not in front of wall {wall.name!r}: its "
                         f"distance along the wall's normal is {d:g} m; it must be > "
                         f"{MIN_EYE_DISTANCE_M:g} m")
    s = near / d
    P = frustum(float(np.dot(vr, va)) * s, float(np.dot(vr, vb)) * s,
                float(np.dot(vu, va)) * s, float(np.dot(vu, vc)) * s, near, far)
    V = np.eye(4)
    V[:3, :3] = np.stack([vr, vu, vn])
    V[:3, 3] = -V[:3, :3] @ pe
    return P, V


def recut(projection: np.ndarray, near: float, far: float) -> np.ndarray:
    """`projection`, a `frustum` (as `off_axis` makes), cut at other `near` and `far` planes:
    the same picture, only the depths it keeps and their mapping differ."""
    if not (np.isfinite(near) and np.isfinite(far) and 0 < near < far):
        raise ValueError(f"near and far must be finite with 0 < near < far, got {near=!r}, "
                         f"{far=!r}")
    cut = np.array(projection, dtype=np.float64)
    cut[2, 2:] = -(far + near) / (far - near), -2 * far * near / (far - near)
    return cut


def project_to_pixels(wall: Wall, eye: object, points: object) -> np.ndarray:
    """(N, 2) window coordinates of room `points` (N, 3) on `wall` as seen from `eye`.

    x counts pixels from the wall's left edge, y from its bottom edge (GL convention, the
    viewport being (0, 0, width_px, height_px)); points behind the eye are NaN. Nothing is
    clipped: points off the wall land outside [0, width_px] × [0, height_px].
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    P, V = off_axis(wall, eye)
    clip = np.concatenate([pts, np.ones((len(pts), 1))], axis=1) @ (P @ V).T
    w = clip[:, 3:4]
    size = np.asarray(wall.resolution, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # at w -> 0: inf
        px = (clip[:, :2] / w + 1.0) * 0.5 * size
    px[w[:, 0] <= 0.0] = np.nan  # w is the depth in front of the eye
    return px


def eye_positions(head_position: object, head_orientation_xyzw: object, ipd: float = 0.064,
                  stereo: bool = False) -> dict[str, np.ndarray]:
    """Eye positions (m) of a tracked head: {"center"} in mono, {"left", "right"} in stereo.

    The quaternion (x, y, z, w) turns the head from looking along +y with +x to its right
    and +z up; it is normalized here. Stereo eyes sit ∓ipd/2 along the head's right axis.
    """
    p = _vec3("head_position", head_position)
    q = np.asarray(head_orientation_xyzw, dtype=np.float64)
    if q.shape != (4,) or not np.isfinite(q).all() or not np.linalg.norm(q) > 0:
        raise ValueError("head_orientation_xyzw must be 4 finite numbers (x, y, z, w), not all "
                         f"zero, got {head_orientation_xyzw!r}")
    if not (np.isfinite(ipd) and ipd >= 0):
        raise ValueError(f"ipd must be finite and >= 0 (metres), got {ipd=!r}")
    if not stereo:
        return {"center": p}
    x, y, z, w = q / np.linalg.norm(q)
    right = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w)])
    return {"left": p - 0.5 * ipd * right, "right": p + 0.5 * ipd * right}


def gl_matrix(m: object) -> bytes:
    """A 4×4 matrix as 64 bytes of float32 column-major, as a GLSL `mat4` uniform wants."""
    a = np.asarray(m)
    if a.shape != (4, 4):
        raise ValueError(f"a GL matrix must have shape (4, 4), got {a.shape}")
    return np.ascontiguousarray(a.T, dtype="f4").tobytes()


def matrices_for_gl(P: object, V: object) -> bytes:
    """P then V as 128 bytes of float32 column-major (e.g. a std140 block of two mat4)."""
    return gl_matrix(P) + gl_matrix(V)
