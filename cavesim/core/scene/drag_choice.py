"""Which drag law a particle class gets when its scene names none: the loader's rule.

Schiller-Naumann (cavesim.core.drag) where the class's particle Reynolds number at the slip
it keeps at the scene's speeds reaches STOKES_REYNOLDS_LIMIT, Stokes below, where it is
within 5% and cheaper (its code is compiled out of a scene with no such class). The slip
scale is the larger of the class's settling speed and its lag behind the flow.
"""

from __future__ import annotations

import math

from cavesim.core.drag import STOKES_REYNOLDS_LIMIT, terminal_speed
from cavesim.core.limits import ROTOR_SPEED_RANGE
from cavesim.core.scene.model import DragLaw, Field, FieldKind, Helicopter, ParticleClass


def flow_scales(field: Field | None, helicopter: Helicopter | None) -> tuple[float, float]:
    """(U, L): the largest flow speed a scene's field reaches (m/s) and the length over which
    it changes (m); (0, inf) where the loader cannot tell without reading a file's data."""
    if field is None:
        return 0.0, math.inf
    p = field.params
    if field.kind is FieldKind.UNIFORM:
        return math.hypot(*p["velocity"]), math.inf
    if field.kind is FieldKind.VORTEX:
        swirl = abs(p["circulation"]) / (2 * math.pi * p["core_radius"])
        return max(swirl, abs(p["axial_speed"])), p["core_radius"]
    if field.kind is FieldKind.DOWNWASH:
        return 2.0 * p["induced_velocity"], p["rotor_radius"]
    if field.kind is FieldKind.ROTOR:  # the far wake, 2 v_i, at the fastest rotor speed
        hover = math.sqrt(helicopter.weight / (2 * helicopter.air_density
                                               * helicopter.disk_area))
        return 2.0 * ROTOR_SPEED_RANGE[1] * hover, helicopter.rotor_radius
    return 0.0, math.inf


def slip_scale(tau: float, settling: float, flow_speed: float, flow_length: float) -> float:
    """The slip a class keeps at a scene's speeds: its settling speed, or the lag
    U St / (1 + St) of a first-order response to a flow that changes by U over L
    (Stokes number St = tau U / L), whichever is larger."""
    stokes_number = tau * flow_speed / flow_length
    return max(settling, flow_speed * stokes_number / (1.0 + stokes_number))


def chosen_law(particle: ParticleClass, nu: float, mu: float, gravity: float,
               flow: tuple[float, float]) -> DragLaw:
    """Schiller-Naumann where the class's Reynolds number at its slip scale reaches
    STOKES_REYNOLDS_LIMIT, else Stokes (compiled out: cheaper, and exact there)."""
    settling = terminal_speed(particle, False, nu, mu, gravity)
    slip = slip_scale(particle.relaxation_time(mu), settling, *flow)
    reynolds = slip * particle.diameter / nu
    return DragLaw.SCHILLER_NAUMANN if reynolds >= STOKES_REYNOLDS_LIMIT else DragLaw.STOKES
