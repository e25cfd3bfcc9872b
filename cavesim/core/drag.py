"""Drag beyond Stokes: the Schiller-Naumann law, settling speeds, and which classes need it.

Stokes drag relaxes a particle's slip u - v at the rate 1/tau, tau = rho_p d² / (18 mu).
Once the particle Reynolds number Re = |u - v| d / nu nears one, the wake adds drag;
Schiller & Naumann (1933) fit it as C_D = 24/Re (1 + 0.15 Re^0.687), within about 5% of the
standard drag curve for Re < 800 (Clift, Grace & Weber 1978, "Bubbles, Drops, and
Particles", table 5.2). The drag is the Stokes drag times f(Re) = 1 + 0.15 Re^0.687, so the
slip relaxes at the rate f(Re)/tau. Twin of `drag_rate` in shaders/include/forces.glsl;
the loader gives each class its law (`cavesim.core.features.schiller_naumann`) unless the scene
names one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the scene's loader uses this module: types only, no import cycle
    from cavesim.core.scene.model import ParticleClass

SCHILLER_NAUMANN_COEFFICIENT = 0.15
SCHILLER_NAUMANN_EXPONENT = 0.687
# Below this Re Stokes' drag is within 5% of Schiller-Naumann's (0.15 * 0.2^0.687 = 0.049)
STOKES_REYNOLDS_LIMIT = 0.2


def drag_factor(reynolds):
    """f(Re) = 1 + 0.15 Re^0.687: Schiller-Naumann's drag over Stokes' at the same slip."""
    return 1.0 + SCHILLER_NAUMANN_COEFFICIENT * reynolds**SCHILLER_NAUMANN_EXPONENT


def terminal_speed(particle: ParticleClass, schiller_naumann: bool, nu: float, mu: float,
                   gravity: float) -> float:
    """Settling speed in still air (m/s): the v with f(v d / nu) v = g tau (f = 1: Stokes)."""
    stokes = gravity * particle.relaxation_time(mu)
    if not schiller_naumann or stokes == 0.0:
        return stokes
    low, high = 0.0, stokes  # f(Re) v grows with v and f >= 1: one root in (0, stokes]
    for _ in range(200):
        mid = 0.5 * (low + high)
        if drag_factor(mid * particle.diameter / nu) * mid < stokes:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)
