"""The rotor downwash in portable arithmetic: `flow_at` of shaders/include/rotor.glsl,
operation by operation in float32 (float64 reference and the model's physics:
cavesim/core/helicopter/rotor.py downwash).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.portable.arithmetic import (
    f_add,
    f_div,
    f_exp,
    f_length,
    f_mul,
    f_pow,
    f_sqrt,
    f_sub,
)
from cavesim.core.portable.builtins import glsl_clamp, glsl_max
from cavesim.core.portable.constants import (
    JET_DECAY,
    JET_GROWTH,
    JET_THICKNESS,
    TURN_HEIGHT,
    UPWASH_HEIGHT,
    WAKE_FLOOR,
)

ZERO, HALF, ONE = np.float32(0.0), np.float32(0.5), np.float32(1.0)
ONE_AND_HALF, TWO_AND_HALF = np.float32(1.5), np.float32(2.5)


def dilution(height: np.ndarray, R: np.float32) -> np.ndarray:
    x = f_div(height, f_mul(TWO_AND_HALF, R))
    return f_exp(-f_mul(x, x))


def wake_growth(h: np.ndarray, R: np.float32) -> np.ndarray:
    """1 + h / sqrt(h^2 + R^2): the wake's speed at depth h below the disk, in units of v_i."""
    return f_add(ONE, f_div(h, f_sqrt(f_add(f_mul(h, h), f_mul(R, R)))))


def flow_at(p: np.ndarray, hub, v_i, rotor_radius, ground_z) -> np.ndarray:
    """Flow velocity (N, 3) at points (N, 3) under the rotor hub (the uniforms' float32 bits)."""
    hub = np.asarray(hub, dtype=np.float32)
    R, vi, ground = np.float32(rotor_radius), np.float32(v_i), np.float32(ground_z)
    if vi <= 0:
        return np.zeros_like(p)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _flow(p, hub, vi, R, ground)


def _flow(p, hub, vi, R, ground):
    # every branch of the shader's per-particle selections is computed and then selected
    d = f_sub(p[:, :2], hub[:2])
    r = f_length(d)
    depth = f_sub(hub[2], p[:, 2])
    w_axis = f_mul(vi, wake_growth(depth, R))
    slip = f_mul(R, f_sqrt(f_div(vi, glsl_max(w_axis, f_mul(WAKE_FLOOR, vi)))))
    r_slip = f_div(r, slip)
    q = f_mul(r_slip, r_slip)
    edge = f_div(ONE, f_add(ONE, f_mul(f_mul(f_mul(q, q), q), q)))
    zeta = glsl_max(f_sub(p[:, 2], ground), ZERO)
    hub_height = glsl_max(f_sub(hub[2], ground), ZERO)
    turn = f_sub(ONE, f_exp(-f_div(zeta, f_mul(TURN_HEIGHT, R))))
    thickness = f_add(f_mul(JET_THICKNESS, R), f_mul(JET_GROWTH, glsl_max(f_sub(r, R), ZERO)))
    height_in_jet = f_div(zeta, thickness)
    profile = f_mul(height_in_jet, f_exp(f_sub(ONE, height_in_jet)))
    w_ground = f_mul(vi, wake_growth(hub_height, R))
    ramp = np.where(r < R, f_div(r, R), f_pow(f_div(R, glsl_max(r, R)), JET_DECAY))
    jet = f_mul(f_mul(w_ground, dilution(hub_height, R)), ramp)
    u_r = f_mul(jet, profile)
    separation = glsl_clamp(f_div(f_sub(r, f_mul(ONE_AND_HALF, R)), f_mul(ONE_AND_HALF, R)),
                            ZERO, ONE)
    rise = f_div(zeta, f_mul(UPWASH_HEIGHT, R))
    upwash = f_mul(f_mul(f_mul(f_mul(HALF, jet), separation), rise), f_exp(f_sub(ONE, rise)))
    radial = np.where((r > 0)[:, None], f_div(d, r[:, None]), ZERO)
    wake_dilution = np.where(depth > 0, f_sqrt(dilution(depth, R)), ONE)
    downdraft = f_mul(f_mul(f_mul(w_axis, edge), turn), wake_dilution)
    out = np.empty_like(p)
    out[:, :2] = f_mul(radial, u_r[:, None])
    out[:, 2] = f_sub(upwash, downdraft)
    return out
