"""Rotor momentum theory on the master: the induced velocity at the disk, in and out of
ground effect, and the saltation the wall jet drives (the flow itself: `downwash`).

Thrust is T = W s² (s: rotor speed over hover speed; in hover T = W); out of ground effect
the induced velocity is v = sqrt(T / (2 rho A)). Near the ground the same thrust needs less
induced velocity: Cheeseman & Bennett (1955, ARC R&M 3021) model the ground by an image
source, which at constant induced power raises thrust by 1 / (1 - (R/4z)²); at constant
thrust (the hover trim, T = W) it is the induced velocity, and with it the induced power,
that falls by (1 - (R/4z)²).
"""

from __future__ import annotations

import numpy as np

from cavesim.core.scene.model import Helicopter

# The image model leaves its range close in (it reaches 0 at z = R/4): below z = R/2 the
# factor is held at its value there, 0.75 (a helicopter on its skids has its hub near R/2).
GROUND_EFFECT_HOLD = 0.5  # rotor radii


def ground_effect(height: float, rotor_radius: float) -> float:
    """v_i in ground effect over v_i out of it at equal thrust, hub `height` above ground
    (Cheeseman & Bennett 1955: 1 - (R/4z)², held below z = R/2)."""
    z = max(height, GROUND_EFFECT_HOLD * rotor_radius)
    return 1.0 - (rotor_radius / (4.0 * z)) ** 2


def induced_velocity(helicopter: Helicopter, rotor_speed: float, height: float) -> float:
    """v_i in m/s at the disk for rotor speed (fraction of hover) and hub height above
    ground: momentum theory at thrust W s², lowered by the ground effect."""
    thrust = helicopter.weight * rotor_speed**2
    out_of_ground_effect = np.sqrt(thrust / (2.0 * helicopter.air_density * helicopter.disk_area))
    return float(out_of_ground_effect * ground_effect(height, helicopter.rotor_radius))


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
