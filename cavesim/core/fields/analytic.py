"""Analytic flow models, evaluated on the grid nodes of a scene's field (float64).

Each model maps node coordinates x, y, z (broadcastable arrays, metres, z up) and the
scene's validated parameters to velocities (..., 3) in m/s. `build_field` in fields.py
casts the result to float32 once; the functions also serve as reference flows in tests.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.scene.model import FieldKind


def uniform_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """The constant flow params["velocity"] = (vx, vy, vz) at every point; shape (..., 3)."""
    return _stack((x, y, z), *_param(params, "velocity", sizes=(3,)))


def vortex_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """Lamb–Oseen vortex about the vertical axis through params["center"] (x, y); (..., 3).

    v_θ(r) = Γ/(2π r) · (1 − exp(−r²/rc²)), counter-clockwise seen from above for Γ > 0, 0 on
    the axis; plus the constant vertical flow `axial_speed` (default 0). Params: center,
    circulation (Γ), core_radius (rc > 0), axial_speed.
    """
    cx, cy = _param(params, "center", sizes=(2, 3))[:2]
    gamma = _param(params, "circulation")
    core = _param(params, "core_radius", positive=True)
    axial = _param(params, "axial_speed", default=0.0)
    dx, dy = np.asarray(x, np.float64) - cx, np.asarray(y, np.float64) - cy
    r2 = dx * dx + dy * dy
    # (1 − exp(−r²/rc²)) / r², whose limit on the axis is 1/rc²; expm1 keeps it exact near 0
    safe_r2 = np.where(r2 > 0, r2, 1.0)
    shape = np.where(r2 > 0, -np.expm1(-r2 / core**2) / safe_r2, 1.0 / core**2)
    scale = gamma / (2 * math.pi) * shape
    return _stack((x, y, z), -scale * dy, scale * dx, axial)


def downwash_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """A simple rotor downwash: a hand-made shape, not momentum theory; (..., 3).

    Params: rotor disk of radius R = `rotor_radius` centred at `rotor_center` (x, y, z),
    `induced_velocity` v_i, ground at `ground_height` (default 0). With r the horizontal
    distance from the rotor axis, h the height above ground, decay = exp(−h / (0.25 R)) and
    footprint = exp(−(r/R)⁴):
    Between ground and disk: w = −v_i · footprint · (1 − decay), and the radial wall flow
    u_r = v_i · R / max(r, R) · decay · smoothstep(0.5 R, R, r).
    Above the disk: weak inflow w = −0.5 v_i · footprint · exp(−(z − z_rotor)/R), no u_r.
    Below ground: 0. Not divergence-free, and w jumps by 0.5 v_i · footprint at the disk plane.
    """
    cx, cy, cz = _param(params, "rotor_center", sizes=(3,))
    radius = _param(params, "rotor_radius", positive=True)
    v_i = _param(params, "induced_velocity")
    ground = _param(params, "ground_height", default=0.0)
    if cz <= ground:
        raise FieldError(f"downwash rotor_center z = {cz} must be above ground_height = {ground}")
    dx, dy = np.asarray(x, np.float64) - cx, np.asarray(y, np.float64) - cy
    z = np.asarray(z, np.float64)
    r = np.hypot(dx, dy)
    h = z - ground
    footprint = np.exp(-((r / radius) ** 4))
    decay = np.exp(-np.maximum(h, 0.0) / (0.25 * radius))
    below, above = (h >= 0) & (z <= cz), z > cz
    w_below = -v_i * footprint * (1.0 - decay)
    w_above = -0.5 * v_i * footprint * np.exp(-np.maximum(z - cz, 0.0) / radius)
    w = np.where(below, w_below, np.where(above, w_above, 0.0))
    s = np.clip((r - 0.5 * radius) / (0.5 * radius), 0.0, 1.0)
    ramp = s * s * (3.0 - 2.0 * s)  # smoothstep(0.5 R, R, r)
    u_r = np.where(below, v_i * radius / np.maximum(r, radius) * decay * ramp, 0.0)
    safe_r = np.where(r > 0, r, 1.0)  # u_r is 0 for r < R/2, so the axis needs no direction
    return _stack((x, y, z), u_r * dx / safe_r, u_r * dy / safe_r, w)


def rotating_velocity(t: float, params: Mapping[str, object]) -> np.ndarray:
    """The uniform flow params["velocity"] turned about z by params["angular_speed"] × t
    (rad/s, counter-clockwise seen from above); shape (3,). The closed form a time series
    of `rotating` snapshots interpolates."""
    vx, vy, vz = _param(params, "velocity", sizes=(3,))
    angle = _param(params, "angular_speed") * t
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * vx - s * vy, s * vx + c * vy, vz])


MODELS = {
    FieldKind.UNIFORM: uniform_velocity,
    FieldKind.VORTEX: vortex_velocity,
    FieldKind.DOWNWASH: downwash_velocity,
}

def _param(params: Mapping[str, object], name: str, sizes: tuple[int, ...] = (),
           default: float | None = None, positive: bool = False):
    """params[name] as a finite float, or a tuple of floats when `sizes` lists allowed lengths."""
    value = params.get(name, default)
    if value is None:
        raise FieldError(f"field parameter {name!r} is missing; got parameters {sorted(params)}")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise FieldError(f"field parameter {name!r} must be numeric, got {value!r}") from e
    ok_shape = array.shape == () if not sizes else array.ndim == 1 and len(array) in sizes
    if not ok_shape or not np.isfinite(array).all() or (positive and not (array > 0).all()):
        wanted = f"a list of {' or '.join(map(str, sizes))} numbers" if sizes else "one number"
        raise FieldError(f"field parameter {name!r} must be {wanted}, finite"
                         f"{' and > 0' if positive else ''}, got {value!r}")
    return tuple(array.tolist()) if sizes else float(array)


def _stack(points, u, v, w) -> np.ndarray:
    """Components broadcast to the common shape of the points' coordinates, stacked as (..., 3)."""
    shape = np.broadcast_shapes(*(np.shape(c) for c in points))
    out = np.empty((*shape, 3))
    out[..., 0], out[..., 1], out[..., 2] = u, v, w
    return out
