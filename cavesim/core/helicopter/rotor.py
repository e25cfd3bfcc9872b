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
    """Emission relative to an emitter's rate: (u*/u*_t)³ - 1 above the threshold, else 0."""
    ratio = np.asarray(u_star, dtype=float) / helicopter.threshold_friction_velocity
    return np.maximum(ratio**3 - 1.0, 0.0)
