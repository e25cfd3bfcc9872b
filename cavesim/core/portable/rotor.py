"""The rotor downwash in portable arithmetic: `flow_at` of shaders/include/rotor.glsl,
function by function and operation by operation in float32 (its physics and sources, and
the same functions in float64: cavesim/core/helicopter/downwash.py).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.portable.arithmetic import (
    f_add,
    f_div,
    f_dot,
    f_exp,
    f_mul,
    f_pow,
    f_sqrt,
    f_sub,
)
from cavesim.core.portable.builtins import glsl_max
from cavesim.core.portable.constants import (
    FOUR_PROFILE_INTEGRAL,
    HALF_WIDTH_POWER,
    ONE_FIFTH,
    PROFILE_DECAY,
    PROFILE_FLUX,
    PROFILE_INNER,
    PROFILE_SHAPE,
    TWO_FIFTHS,
    WAKE_SPREADING,
    WALL_JET_GROWTH,
    WALL_JET_WIDTH_SQ,
    WIDTH_POWER,
)

ZERO, QUARTER, HALF, ONE, TWO, FOUR = (np.float32(x) for x in (0.0, 0.25, 0.5, 1.0, 2.0, 4.0))
PROFILE_RISE = np.float32(60.0)
GROWTH_POWER = np.float32(1.25)


def wall_jet(hub_z, ground_z, R):
    """(hub height, width on the axis, r_e², (0.098 H^0.1)²): the frame's wall jet."""
    h = glsl_max(f_sub(hub_z, ground_z), ZERO)
    H = glsl_max(h, f_mul(HALF, R))
    ratio = f_div(R, f_mul(FOUR, H))
    k = f_sub(ONE, f_mul(ratio, ratio))
    growth = f_add(ONE, f_div(h, f_sqrt(f_add(f_mul(h, h), f_mul(R, R)))))
    m = f_div(f_mul(f_mul(WAKE_SPREADING, h), growth), f_mul(TWO, R))
    spread = f_sqrt(f_add(ONE, f_mul(m, m)))
    source_width = f_div(f_mul(f_mul(f_mul(R, spread), f_sqrt(growth)), k),
                         FOUR_PROFILE_INTEGRAL)
    H_fifth = f_pow(H, ONE_FIFTH)
    growth_radius = f_pow(f_div(f_mul(f_mul(R, spread), k), f_mul(WALL_JET_GROWTH, H_fifth)),
                          GROWTH_POWER)
    return (h, source_width, f_mul(growth_radius, growth_radius),
            f_mul(WALL_JET_WIDTH_SQ, H_fifth))


def wake(q, z, h, R):
    """(W, dW/dz, dW/d(r²)): the slipstream."""
    depth = f_sub(h, z)
    RR = f_mul(R, R)
    s = f_sqrt(f_add(f_mul(depth, depth), RR))
    g = f_add(ONE, f_div(depth, s))
    g_d = f_div(RR, f_mul(f_mul(s, s), s))
    two_R = f_mul(TWO, R)
    m = f_div(f_mul(f_mul(WAKE_SPREADING, depth), g), two_R)
    sigma = f_sqrt(f_add(ONE, f_mul(m, m)))
    m_d = f_div(f_mul(WAKE_SPREADING, f_add(g, f_mul(depth, g_d))), two_R)
    sigma_d = f_div(f_mul(m, m_d), sigma)
    tube = f_mul(RR, f_mul(sigma, sigma))
    c = f_div(g, tube)
    c_d = f_div(f_sub(g_d, f_div(f_mul(f_mul(TWO, g), sigma_d), sigma)), tube)
    x = f_mul(q, c)
    x2 = f_mul(x, x)
    tilde = f_div(ONE, f_sqrt(f_sqrt(f_add(ONE, f_mul(x2, x2)))))
    tilde2 = f_mul(tilde, tilde)
    tilde_x = -f_mul(f_mul(x2, x), f_mul(f_mul(tilde2, tilde2), tilde))
    speed = f_div(g, sigma)
    speed_d = f_div(f_sub(g_d, f_div(f_mul(g, sigma_d), sigma)), sigma)
    return (f_mul(speed, tilde),
            -f_add(f_mul(speed_d, tilde), f_mul(f_mul(speed, tilde_x), f_mul(q, c_d))),
            f_mul(f_mul(speed, tilde_x), c))


def entrainment(q, z, growth_radius_sq, R):
    """(E, dE/dz, dE/d(r²)): the wall jet's entrainment."""
    u = f_div(q, growth_radius_sq)
    grow = f_add(ONE, f_mul(u, u))
    grown = f_pow(grow, ONE_FIFTH)
    grown_q = f_div(f_mul(f_mul(TWO_FIFTHS, u), grown), f_mul(grow, growth_radius_sq))
    reach = f_add(q, f_mul(R, R))
    fade = f_exp(-f_div(f_mul(z, z), reach))
    extra = f_mul(f_sub(grown, ONE), fade)
    return (f_add(ONE, extra), -f_div(f_mul(f_mul(TWO, z), extra), reach),
            f_add(f_mul(grown_q, fade), f_div(f_mul(extra, f_mul(z, z)), f_mul(reach, reach))))


def jet_width(q, source_width, width_coefficient_sq, R):
    """(delta, d delta / d(r²))."""
    axis = f_add(q, f_mul(QUARTER, f_mul(R, R)))
    far4 = f_mul(f_mul(width_coefficient_sq, width_coefficient_sq), f_pow(axis, WIDTH_POWER))
    source2 = f_mul(source_width, source_width)
    width4 = f_add(f_mul(source2, source2), far4)
    width = f_sqrt(f_sqrt(width4))
    return width, f_mul(f_div(f_mul(HALF_WIDTH_POWER, far4), f_mul(axis, width4)), width)


def jet_profile(eta):
    """(T, dT/deta): the wall jet's flux fraction below eta."""
    ea = f_exp(-f_mul(PROFILE_DECAY, eta))
    eb = f_exp(-f_mul(PROFILE_RISE, eta))
    outer = f_add(f_div(f_sub(ONE, ea), PROFILE_DECAY),
                  f_div(f_mul(PROFILE_SHAPE,
                              f_sub(ONE, f_mul(f_add(ONE, f_mul(PROFILE_DECAY, eta)), ea))),
                        f_mul(PROFILE_DECAY, PROFILE_DECAY)))
    inner = f_add(f_div(f_sub(ONE, eb), PROFILE_RISE),
                  f_div(f_mul(PROFILE_INNER,
                              f_sub(ONE, f_mul(f_add(ONE, f_mul(PROFILE_RISE, eta)), eb))),
                        f_mul(PROFILE_RISE, PROFILE_RISE)))
    f = f_sub(f_mul(f_add(ONE, f_mul(PROFILE_SHAPE, eta)), ea),
              f_mul(f_add(ONE, f_mul(PROFILE_INNER, eta)), eb))
    return f_div(f_sub(outer, inner), PROFILE_FLUX), f_div(f, PROFILE_FLUX)


def layer(q, z, source_width, width_coefficient_sq, R):
    """(T, dT/dz, dT/d(r²)): the wall jet's layer."""
    width, width_q = jet_width(q, source_width, width_coefficient_sq, R)
    eta = f_div(z, width)
    t, t_eta = jet_profile(eta)
    return t, f_div(t_eta, width), -f_div(f_mul(f_mul(t_eta, eta), width_q), width)


def flow_at(p: np.ndarray, hub, v_i, rotor_radius, ground_z) -> np.ndarray:
    """Flow velocity (N, 3) at points (N, 3) under the rotor hub (the uniforms' float32 bits)."""
    hub = np.asarray(hub, dtype=np.float32)
    R, vi, ground = np.float32(rotor_radius), np.float32(v_i), np.float32(ground_z)
    if vi <= 0:
        return np.zeros_like(p)
    h, source_width, growth_radius_sq, width_coefficient_sq = wall_jet(hub[2], ground, R)
    offset = f_sub(p[:, :2], hub[:2])
    q = f_dot(offset, offset)
    height = f_sub(p[:, 2], ground)
    z = np.abs(height)
    w, w_z, w_q = wake(q, z, h, R)
    e, e_z, e_q = entrainment(q, z, growth_radius_sq, R)
    t, t_z, t_q = layer(q, z, source_width, width_coefficient_sq, R)
    we, wt, et = f_mul(w, e), f_mul(w, t), f_mul(e, t)
    G = f_mul(we, t)
    G_z = f_add(f_add(f_mul(w_z, et), f_mul(e_z, wt)), f_mul(t_z, we))
    G_q = f_add(f_add(f_mul(w_q, et), f_mul(e_q, wt)), f_mul(t_q, we))
    up = f_mul(vi, f_add(G, f_mul(q, G_q)))
    out = np.empty_like(p)
    out[:, :2] = f_mul(offset, f_mul(HALF, f_mul(vi, G_z))[:, None])
    out[:, 2] = np.where(height < 0, up, -up)
    return out
