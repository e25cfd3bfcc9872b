"""Rotor momentum theory and the downwash flow (numpy twin of shaders/include/rotor.glsl).

Induced velocity v_i = sqrt(T / (2 rho A)) with thrust T = W s² k_ground (s: rotor speed
over hover speed; k_ground = 1 / (1 - (R/4h)²), Cheeseman-Bennett, held at its value at
h = R/2 closer in). The flow, axisymmetric about the rotor axis:
  - the wake: downward speed v_i (1 + d / sqrt(d² + R²)) at depth d below the disk (the
    actuator disk's vortex-cylinder solution: v_i at the disk, 2 v_i far below, inflow
    above), inside the slipstream radius R_s = R sqrt(v_i / w) (mass conservation: the
    wake contracts to R/sqrt(2)), with a smooth edge;
  - near the ground the vertical flow turns: it fades as 1 - exp(-zeta / 0.3R);
  - the radial wall jet along the ground: speed w_g (the wake's speed at the ground) times
    r/R inside one radius and (R/r)^1.1 beyond, with a profile in height peaking at the
    jet's thickness 0.1R + 0.05 (r - R);
  - beyond 1.5R the wall jet separates and rolls up: an upwash of half the jet's speed,
    growing to 3R, peaking 0.8R above the ground (the rising ring of a brownout cloud);
  - the wake dilutes with the hub's height h: everything at the ground is scaled by
    exp(-(h / 2.5R)²), so a helicopter high up raises no dust.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.scene.model import Helicopter

GRAVITY = 9.81
KARMAN = 0.4


def ground_effect(height: float, rotor_radius: float) -> float:
    """Thrust ratio in ground effect at hub height `height` above the ground."""
    h = max(height, rotor_radius / 2)
    return 1.0 / (1.0 - (rotor_radius / (4.0 * h)) ** 2)


def induced_velocity(helicopter: Helicopter, rotor_speed: float, height: float) -> float:
    """v_i in m/s for rotor speed (fraction of hover) and hub height above ground."""
    thrust = helicopter.weight * rotor_speed**2 * ground_effect(height, helicopter.rotor_radius)
    return float(np.sqrt(thrust / (2.0 * helicopter.air_density * helicopter.disk_area)))


def dilution(hub_height: float, rotor_radius: float):
    return np.exp(-(hub_height / (2.5 * rotor_radius)) ** 2)


def jet_thickness(r, rotor_radius: float):
    return 0.1 * rotor_radius + 0.05 * np.maximum(r - rotor_radius, 0.0)


def ground_jet_speed(r, hub_height: float, v_i: float, rotor_radius: float):
    """Peak radial speed of the wall jet at distance r from the rotor axis (m/s)."""
    R = rotor_radius
    w_ground = v_i * (1.0 + hub_height / np.sqrt(hub_height**2 + R**2))
    r = np.asarray(r, dtype=float)
    ramp = np.where(r < R, r / R, (R / np.maximum(r, R)) ** 1.1)
    return w_ground * dilution(hub_height, R) * ramp


def downwash(points, hub, v_i: float, rotor_radius: float, ground_z: float, dtype=np.float64):
    """Flow velocity (N, 3) at world points (N, 3) under a rotor hub at `hub`."""
    p = np.asarray(points, dtype=dtype)
    hub = np.asarray(hub, dtype=dtype)
    R, one = dtype(rotor_radius), dtype(1)
    if v_i <= 0:
        return np.zeros_like(p)
    dx, dy = p[:, 0] - hub[0], p[:, 1] - hub[1]
    r = np.sqrt(dx * dx + dy * dy)
    depth = hub[2] - p[:, 2]
    w_axis = v_i * (one + depth / np.sqrt(depth * depth + R * R))
    slip = R * np.sqrt(v_i / np.maximum(w_axis, dtype(1e-3) * v_i))
    q = (r / slip) ** 2
    edge = one / (one + q * q * q * q)
    zeta = np.maximum(p[:, 2] - dtype(ground_z), 0)
    hub_height = np.maximum(hub[2] - dtype(ground_z), 0)
    turn = one - np.exp(-zeta / (dtype(0.3) * R))
    thin = jet_thickness(r, R).astype(dtype)
    profile = (zeta / thin) * np.exp(one - zeta / thin)
    jet = ground_jet_speed(r, hub_height, v_i, R).astype(dtype)
    u_r = jet * profile
    separation = np.clip((r - dtype(1.5) * R) / (dtype(1.5) * R), 0, 1)
    rise = zeta / (dtype(0.8) * R)
    upwash = dtype(0.5) * jet * separation * rise * np.exp(one - rise)
    safe_r = np.where(r > 0, r, one)
    out = np.empty_like(p)
    out[:, 0] = np.where(r > 0, dx / safe_r, 0) * u_r
    out[:, 1] = np.where(r > 0, dy / safe_r, 0) * u_r
    out[:, 2] = upwash - w_axis * edge * turn * np.where(depth > 0, dilution(depth, R) ** 0.5,
                                                          one)
    return out


def friction_velocity(helicopter: Helicopter, r, hub_height: float, v_i: float):
    """Surface friction velocity u* (m/s) under the wall jet at distance r: log law from
    the jet's peak speed at its thickness."""
    R = helicopter.rotor_radius
    speed = ground_jet_speed(r, hub_height, v_i, R)
    return KARMAN * speed / np.log(jet_thickness(np.asarray(r, float), R)
                                   / helicopter.roughness_length)


def saltation_factor(helicopter: Helicopter, u_star):
    """A following emitter's rate factor: the sand flux over its scale, Q / Q_t.

    The flux is linear in the shear stress rho_a u*² above its threshold:
    Q = C (rho_a / g) u*_t (u*² - u*_t²), 0 below (Martin & Kok 2017, Sci. Adv. 3,
    e1602569: saltation heights and grain speeds stay the same as u* grows, so the flux
    grows with the stress, as their field data show; C is a dimensionless constant fitted
    to such data). Over Q_t = C (rho_a / g) u*_t³, the flux at u* = sqrt(2) u*_t, the
    factor is (u*/u*_t)² - 1: the emitter's rate is its particles per second at Q = Q_t.

    Sand emitters release grains in proportion to Q. Fine dust is held by cohesion far
    beyond any threshold the jet reaches; saltating grains knock it loose (sandblasting):
    its vertical flux is F = alpha Q, alpha of 1e-4 to 5e-2 1/m for soils of 0 to 20% clay
    (Marticorena & Bergametti 1995, J. Geophys. Res. 100, 16415: log10 alpha[1/cm] =
    0.134 %clay - 6; Shao 2001, J. Geophys. Res. 106, 20239, derives it from the grains'
    impacts). So a dust emitter takes the same factor: no threshold of its own, dust rises
    only where sand saltates, and alpha (the soil) sets the dust emitters' rates against
    the sand's.
    """
    ratio = np.asarray(u_star, dtype=float) / helicopter.threshold_friction_velocity
    return np.maximum(ratio**2 - 1.0, 0.0)
