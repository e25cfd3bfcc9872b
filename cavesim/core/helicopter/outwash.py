"""The downwash's outwash measured as experimenters measure a wall jet, beside the published
radial wall-jet correlations it is validated against (tests/unit/test_downwash.py holds the
tolerances; cavesim/tools/reports/outwash_figure.py plots them).

No digitised rotor outwash measurements were at hand (Fradenburgh 1960, Silva & Riser 2011
and Tanner et al. 2015 publish theirs as figures); the references are correlations fitted
to measured radial wall jets of impinging round jets:

- Poreh, Tsuei & Cermak 1967 (J. Appl. Mech. 34:457): u_max = 1.03 K^1/2 H^0.1 r^-1.1 and
  half-width delta = 0.098 H^0.1 r^0.9 (K: the jet's kinematic momentum flux, T / rho for a
  rotor; H: the jet's height). Far from the rotor (r >= 5R and r >= H) the flow is that
  self-similar jet; nearer in, the wake's own width and speed set it.
- Verhoff 1963 (Princeton University report 626): u / u_max = 1.48 eta^(1/7)
  (1 - erf(0.68 eta)), eta = z / delta.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.core.helicopter.downwash import (
    WALL_JET_SPEED,
    WALL_JET_SPEED_EXPONENT,
    WALL_JET_WIDTH,
    WALL_JET_WIDTH_EXPONENT,
    downwash,
)
from cavesim.core.helicopter.rotor import GROUND_EFFECT_HOLD

PROFILE_SAMPLES = 6001  # heights a vertical profile is sampled at, up to 2 rotor radii


def verhoff_profile(eta):
    """Verhoff's radial wall-jet profile u / u_max at eta = z / delta (half-width)."""
    eta = np.asarray(eta, dtype=np.float64)
    return 1.48 * eta ** (1 / 7) * (1 - np.vectorize(math.erf)(0.68 * eta))


def poreh_peak_speed(thrust_velocity: float, rotor_radius: float, hub_height: float, r):
    """Poreh et al.'s u_max (m/s) at distances r for a rotor of hover-equivalent induced
    velocity v_T (T / rho = 2 pi R² v_T²) with its hub `hub_height` above the ground."""
    momentum = 2 * math.pi * rotor_radius**2 * thrust_velocity**2
    H = max(hub_height, GROUND_EFFECT_HOLD * rotor_radius)
    decay = np.asarray(r, float) ** WALL_JET_SPEED_EXPONENT
    return WALL_JET_SPEED * math.sqrt(momentum) * H**0.1 * decay


def poreh_half_width(rotor_radius: float, hub_height: float, r):
    """Poreh et al.'s wall-jet half-width (m) at distances r."""
    H = max(hub_height, GROUND_EFFECT_HOLD * rotor_radius)
    return WALL_JET_WIDTH * H**0.1 * np.asarray(r, float) ** WALL_JET_WIDTH_EXPONENT


@dataclass(frozen=True)
class Profile:
    """The downwash's radial velocity against height at one distance from the axis."""

    z: np.ndarray  # m above the ground
    u: np.ndarray  # m/s, outward
    peak_speed: float  # m/s
    peak_height: float  # m
    half_width: float  # m: the height above the peak where u falls to half of it


def outwash_profile(r: float, hub_height: float, v_i: float, rotor_radius: float) -> Profile:
    """The outwash at distance r from the rotor axis, hub `hub_height` above the ground."""
    z = np.linspace(0.0, 2.0 * rotor_radius, PROFILE_SAMPLES)
    points = np.column_stack([np.full_like(z, r), np.zeros_like(z), z])
    u = downwash(points, (0.0, 0.0, hub_height), v_i, rotor_radius, 0.0)[:, 0]
    peak = int(np.argmax(u))
    above = peak + int(np.argmax(u[peak:] < 0.5 * u[peak]))
    return Profile(z, u, float(u[peak]), float(z[peak]), float(z[above]))

