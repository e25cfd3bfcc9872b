"""The rotor's downwash: the float64 twin of shaders/include/rotor.glsl (the GPU evaluates
it per particle from the frame's hub and induced velocity v_i; the master reads the wall
jet's friction velocity from it for the saltation).

The flow is axisymmetric about the rotor axis and built from a Stokes stream function,
psi = -Phi / 2 pi, where Phi(r, z) is the volume flux down through the disk of radius r at
height z above the ground. Then u_r = (1/2 pi r) dPhi/dz and u_z = -(1/2 pi r) dPhi/dr, so
div u = 0 identically, and the velocity is as smooth as Phi: every factor below is an
analytic function of r² and z. Phi = 0 on the axis and on the ground (no flow through it).

    Phi = Phi_wake(r², z) * E(r², z) * T(z / delta(r²))

- Phi_wake, the slipstream: the flux pi R² v_i through the disk in a tube of radius b(z)
  whose mean speed w(d) = v_i (1 + d / sqrt(d² + R²)) at depth d below the disk is the
  actuator disk's (its vortex-cylinder solution: v_i at the disk, 2 v_i far below, the
  inflow above it); b contracts by continuity toward R/sqrt 2. The far wake spreads like a
  round turbulent jet (half-width 0.094 d, momentum kept). Across the tube the flux grows
  as S(x) = x / (1 + x⁴)^(1/4), x = (r/b)²: a smooth shear layer instead of a vortex sheet.
- T, the wall jet's profile across its half-width delta: the flux fraction below z of the
  profile f(eta) = (1 + c eta) e^(-a eta) - (1 + (b - a + c) eta) e^(-b eta), a fit to
  Verhoff's radial wall-jet profile (see PROFILE_*); f(0) = f'(0) = 0, so reflecting Phi
  oddly through the ground continues the flow below it (where only a step's stages and the
  accuracy case's particles go) C2 across z = 0.
- E, the wall jet's entrainment: the flux along the ground grows from what the wake brings
  to r^0.8 far out, drawn from the air above (to a height ~ sqrt(r² + R²)).
- delta(r) starts at the thickness that carries the wake's flux at the speed the air has
  when back at ambient pressure (Bernoulli behind the disk: sqrt(2T / rho A) = 2 v_T), and
  grows far out as Poreh, Tsuei & Cermak's radial wall jet, whose peak speed the flux
  growth is matched to (WALL_JET_*): u_max ~ K^1/2 H^0.1 r^-1.1 with K = T / rho.

The thrust comes from v_i and the hub height through the same ground effect the master
used (rotor.ground_effect): v_T = v_i / k(h) is the rotor's v_i out of ground effect and
T = 2 rho pi R² v_T². The whole field scales with v_i.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.core.air import KARMAN
from cavesim.core.helicopter.rotor import ground_effect
from cavesim.core.scene.model import Helicopter

# The far wake spreads as a round turbulent jet: half-width 0.094 d (Hussein, Capp &
# George 1994, J. Fluid Mech. 258; Pope, Turbulent Flows 2000, sec. 5.1). With sigma the
# tube's widening, b = (R / sqrt 2) sigma and the half-width at 0.963 b, the far-wake
# sigma = 0.094 d / (0.963 R / sqrt 2) = 0.138 d / R.
WAKE_SPREADING = 0.138

# Radial wall jet of an impinging round jet, Poreh, Tsuei & Cermak 1967 (J. Appl. Mech.
# 34:457): u_max = 1.03 K^1/2 H^0.1 r^-1.1 and half-width 0.098 H^0.1 r^0.9, K the jet's
# kinematic momentum flux (here T / rho), H its height (here the hub's, held at R/2 like
# the ground effect). The two carry half of K at r = H and lose it to wall friction as
# r^-0.3.
WALL_JET_SPEED = 1.03
WALL_JET_WIDTH = 0.098
WALL_JET_SPEED_EXPONENT = -1.1
WALL_JET_WIDTH_EXPONENT = 0.9
FLUX_GROWTH_EXPONENT = 0.8  # r u_max delta ~ r^(1 - 1.1 + 0.9)

# The wall jet's profile u/u_max = f(eta) / f_max, eta = z / delta, fitted to Verhoff's
# empirical wall-jet profile u/u_max = 1.48 eta^(1/7) (1 - erf(0.68 eta)) (Verhoff 1963,
# Princeton University report 626) within 0.018 for 0.1 <= eta <= 2.5 (below eta = 0.1 its
# power law has no smooth fit). Radial wall jets keep one profile too (Poreh et al. found
# theirs similar and of Glauert's form: Glauert 1956, J. Fluid Mech. 1:625).
PROFILE_DECAY = 2.1  # a
PROFILE_RISE = 60.0  # b: the inner layer, delta / 60 thick
PROFILE_SHAPE = 3.3  # c
PROFILE_INNER = PROFILE_RISE - PROFILE_DECAY + PROFILE_SHAPE  # b - a + c: makes f'(0) = 0
PROFILE_FLUX = (1 / PROFILE_DECAY + PROFILE_SHAPE / PROFILE_DECAY**2
                - 1 / PROFILE_RISE - PROFILE_INNER / PROFILE_RISE**2)  # integral of f
PROFILE_PEAK = 1.0920453  # f_max, at eta = 0.17655 (tests/unit/test_downwash.py checks both)
PROFILE_PEAK_HEIGHT = 0.17655
PROFILE_INTEGRAL = PROFILE_FLUX / PROFILE_PEAK  # integral of u/u_max over eta

# Far out the flux Q (r/r_e)^0.8 at width 0.098 H^0.1 r^0.9 has Poreh's u_max: r_e^0.8 =
# Q / (2 pi F 1.03 0.098 K^1/2 H^0.2) with Q / K^1/2 = sqrt(pi/2) R sigma k (F: the profile's
# integral), so r_e^0.8 = R sigma k / (WALL_JET_GROWTH H^0.2).
WALL_JET_GROWTH = (2 * math.sqrt(2 * math.pi) * WALL_JET_WIDTH * PROFILE_INTEGRAL
                   * WALL_JET_SPEED)

AXIS_SMOOTHING = 0.5  # rotor radii: the width law's r² + (R/2)² keeps it smooth on the axis


@dataclass(frozen=True)
class WallJet:
    """The frame's constants of the flow near the ground (they depend on the hub height h
    and the rotor radius only: the field is v_i times a shape)."""

    hub_height: float
    source_width: float  # m: delta on the axis, from the wake's flux at 2 v_T
    growth_radius_sq: float  # m²: r_e², where the flux starts to grow as r^0.8
    width_coefficient_sq: float  # (0.098 H^0.1)², m^0.2


def wall_jet(hub_height: float, rotor_radius: float) -> WallJet:
    """The wall jet under a hub `hub_height` above the ground (see the module docstring)."""
    h, R = max(hub_height, 0.0), rotor_radius
    H = max(h, 0.5 * R)
    k = ground_effect(h, R)
    growth = 1.0 + h / math.sqrt(h * h + R * R)  # w / v_i at the ground
    spread = math.sqrt(1.0 + (WAKE_SPREADING * h * growth / (2.0 * R)) ** 2)
    # flux pi R² v_i sigma through a tube of radius R sigma / sqrt(growth) at 2 v_T / sigma
    source_width = R * spread * math.sqrt(growth) * k / (4.0 * PROFILE_INTEGRAL)
    growth_radius = (R * spread * k / (WALL_JET_GROWTH * H**0.2)) ** (1.0 / FLUX_GROWTH_EXPONENT)
    return WallJet(h, source_width, growth_radius**2, (WALL_JET_WIDTH * H**0.1) ** 2)


def _profile(eta):
    """(T, dT/deta): the wall jet's flux fraction below eta and its derivative."""
    a, b, c, d = PROFILE_DECAY, PROFILE_RISE, PROFILE_SHAPE, PROFILE_INNER
    ea, eb = np.exp(-a * eta), np.exp(-b * eta)
    flux = ((1 - ea) / a + c * (1 - (1 + a * eta) * ea) / a**2
            - (1 - eb) / b - d * (1 - (1 + b * eta) * eb) / b**2)
    return flux / PROFILE_FLUX, ((1 + c * eta) * ea - (1 + d * eta) * eb) / PROFILE_FLUX


def _width(q, jet: WallJet, R: float):
    """(delta, d delta / d(r²)): delta = (delta_0⁴ + (0.098 H^0.1 (r² + (R/2)²)^0.45)⁴)^1/4."""
    axis = q + (AXIS_SMOOTHING * R) ** 2
    far4 = jet.width_coefficient_sq**2 * axis ** (2 * WALL_JET_WIDTH_EXPONENT)
    width4 = jet.source_width**4 + far4
    width = np.sqrt(np.sqrt(width4))
    return width, WALL_JET_WIDTH_EXPONENT / 2 * far4 / (axis * width4) * width


def _wake(q, z, h: float, R: float):
    """The slipstream, Phi_wake / (pi v_i r²) = (g / sigma) (1 + x⁴)^-1/4 with x = r² g /
    (R sigma)², and its derivatives in z and r²."""
    depth = h - z
    s = np.sqrt(depth * depth + R * R)
    g = 1 + depth / s  # w / v_i
    g_d = R * R / (s * s * s)
    m = WAKE_SPREADING * depth * g / (2 * R)
    sigma = np.sqrt(1 + m * m)
    sigma_d = m * WAKE_SPREADING * (g + depth * g_d) / (2 * R) / sigma
    c = g / (R * R * sigma * sigma)
    c_d = (g_d - 2 * g * sigma_d / sigma) / (R * R * sigma * sigma)
    x = q * c
    x2 = x * x
    tilde = 1 / np.sqrt(np.sqrt(1 + x2 * x2))
    tilde_x = -x2 * x * tilde**5
    speed = g / sigma
    speed_d = (g_d - g * sigma_d / sigma) / sigma
    return (speed * tilde, -(speed_d * tilde + speed * tilde_x * q * c_d),
            speed * tilde_x * c)


def _entrainment(q, z, jet: WallJet, R: float):
    """E = 1 + (E_g - 1) exp(-z² / (r² + R²)), E_g = (1 + (r² / r_e²)²)^0.2, and its
    derivatives in z and r²."""
    u = q / jet.growth_radius_sq
    grown = (1 + u * u) ** (FLUX_GROWTH_EXPONENT / 4)
    grown_q = FLUX_GROWTH_EXPONENT / 2 * u * grown / ((1 + u * u) * jet.growth_radius_sq)
    reach = q + R * R
    fade = np.exp(-z * z / reach)
    return (1 + (grown - 1) * fade, -2 * z * (grown - 1) * fade / reach,
            grown_q * fade + (grown - 1) * fade * z * z / (reach * reach))


def _layer(q, z, jet: WallJet, R: float):
    """The wall jet's flux fraction T(z / delta(r²)) and its derivatives in z and r²."""
    width, width_q = _width(q, jet, R)
    eta = z / width
    layer, layer_eta = _profile(eta)
    return layer, layer_eta / width, -layer_eta * eta * width_q / width


def _flux(q, z, jet: WallJet, R: float, v_i: float):
    """G = Phi / (pi r²) = v_i (Phi_wake / pi v_i r²) E T and its derivatives dG/dz,
    dG/d(r²) at r² = q, height z >= 0: u_r = r G_z / 2 and u_z = -(G + r² G_q)."""
    (w, w_z, w_q), (e, e_z, e_q) = _wake(q, z, jet.hub_height, R), _entrainment(q, z, jet, R)
    t, t_z, t_q = _layer(q, z, jet, R)
    return (v_i * w * e * t, v_i * (w_z * e * t + w * e_z * t + w * e * t_z),
            v_i * (w_q * e * t + w * e_q * t + w * e * t_q))


def _frame(points, hub, ground_z):
    p = np.asarray(points, dtype=np.float64)
    hub = np.asarray(hub, dtype=np.float64)
    offset = p[:, :2] - hub[:2]
    height = p[:, 2] - ground_z
    return offset, np.einsum("ij,ij->i", offset, offset), np.abs(height), np.sign(height)


def downwash(points, hub, v_i: float, rotor_radius: float, ground_z: float, dtype=np.float64):
    """Flow velocity (N, 3) at world points (N, 3) under a rotor hub at `hub` (m/s)."""
    if v_i <= 0:
        return np.zeros(np.shape(points), dtype=dtype)
    offset, q, z, side = _frame(points, hub, ground_z)
    jet = wall_jet(float(hub[2]) - ground_z, rotor_radius)
    G, G_z, G_q = _flux(q, z, jet, rotor_radius, v_i)
    out = np.empty((len(q), 3))
    out[:, :2] = offset * (G_z / 2)[:, None]
    out[:, 2] = -side * (G + q * G_q)
    return out.astype(dtype)


def stream_function(points, hub, v_i: float, rotor_radius: float, ground_z: float):
    """The Stokes stream function psi (m³/s) of `downwash` at world points (N, 3)."""
    offset, q, z, side = _frame(points, hub, ground_z)
    jet = wall_jet(float(hub[2]) - ground_z, rotor_radius)
    return -side * q * _flux(q, z, jet, rotor_radius, v_i)[0] / 2


def jet_peak(r, hub_height: float, v_i: float, rotor_radius: float):
    """(u, z): the radial speed (m/s) at the height z (m) where the wall jet's profile peaks,
    at distances r from the rotor axis."""
    r = np.asarray(r, dtype=np.float64)
    q = r * r
    jet = wall_jet(hub_height, rotor_radius)
    z = PROFILE_PEAK_HEIGHT * _width(q, jet, rotor_radius)[0]
    return r * _flux(q, z, jet, rotor_radius, v_i)[1] / 2, z


def friction_velocity(helicopter: Helicopter, r, hub_height: float, v_i: float):
    """Surface friction velocity u* (m/s) under the wall jet at distances r: the log law
    through the jet's peak, u* = kappa u_peak / ln(z_peak / z0)."""
    speed, z = jet_peak(r, hub_height, v_i, helicopter.rotor_radius)
    return KARMAN * np.maximum(speed, 0.0) / np.log(z / helicopter.roughness_length)
