"""One step of each integrator: (p, v, h, forces) -> (p, v).

Twin of `integrate` in shaders/include/physics.glsl; `INTEGRATORS` maps the scene's
choice to the function, and `ORDERS` gives each method's theoretical order of accuracy.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cavesim.core.scene.model import Integrator
from cavesim.core.twin.forces import ForceModel

Step = Callable[[np.ndarray, np.ndarray, float, ForceModel], tuple[np.ndarray, np.ndarray]]

# Butcher tableaux (c is implied by A for these explicit methods)
RK2_MIDPOINT_A = ((), (0.5,))
RK2_MIDPOINT_B = (0.0, 1.0)
RK4_CLASSIC_A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
RK4_CLASSIC_B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)


def explicit_euler(p, v, h, forces):
    """Explicit (forward) Euler, order 1."""
    a = forces.acceleration(p, v)
    return p + h * v, v + h * a


def semi_implicit_euler(p, v, h, forces):
    """Semi-implicit Euler: drag implicit, the rest explicit, new velocity moves, order 1."""
    f, lam = forces.linear_parts(p, v)
    v = (v + h * f) / (1 + h * lam)
    return p + h * v, v


def trapezoid(p, v, h, forces):
    """UberFlow eq. (1)-(2): Euler velocity, trapezoidal position, order 1."""
    v1 = v + h * forces.acceleration(p, v)
    return p + (0.5 * h) * (v + v1), v1


def verlet(p, v, h, forces):
    """Velocity Verlet with an Euler-predicted velocity for the drag, order 2."""
    a0 = forces.acceleration(p, v)
    p = p + h * v + (0.5 * h * h) * a0
    a1 = forces.acceleration(p, v + h * a0)
    return p, v + (0.5 * h) * (a0 + a1)


def _explicit_runge_kutta(a_table, b_weights) -> Step:
    def step(p, v, h, forces):
        kp, kv = [], []
        for row in a_table:
            ps, vs = p, v
            for coefficient, dp, dv in zip(row, kp, kv, strict=False):
                if coefficient:
                    ps = ps + (coefficient * h) * dp
                    vs = vs + (coefficient * h) * dv
            kp.append(vs)
            kv.append(forces.acceleration(ps, vs))
        dp = sum(w * k for w, k in zip(b_weights, kp, strict=True) if w)
        dv = sum(w * k for w, k in zip(b_weights, kv, strict=True) if w)
        return p + h * dp, v + h * dv

    return step


rk2 = _explicit_runge_kutta(RK2_MIDPOINT_A, RK2_MIDPOINT_B)
rk2.__doc__ = "Explicit midpoint Runge-Kutta, order 2."
rk4 = _explicit_runge_kutta(RK4_CLASSIC_A, RK4_CLASSIC_B)
rk4.__doc__ = "Classic Runge-Kutta, order 4."


def exponential_weights(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """e^-x, phi1 = (1 - e^-x)/x and phi2 = (x - 1 + e^-x)/x^2, accurate for all x >= 0."""
    small = x < 1e-3
    xs = np.where(small, 1.0, x)
    em1 = np.expm1(-xs)
    phi1 = np.where(small, 1 - x / 2 + x * x / 6, -em1 / xs)
    phi2 = np.where(small, 0.5 - x / 6 + x * x / 24, (xs + em1) / (xs * xs))
    return np.exp(-x), phi1, phi2


def exponential(p, v, h, forces):
    """Exact for linear drag with the flow held over the step; stable for any tau/h, order 1."""
    f, lam = forces.linear_parts(p, v)
    e, phi1, phi2 = exponential_weights(lam * h)
    return p + (h * phi1) * v + (h * h * phi2) * f, e * v + (h * phi1) * f


INTEGRATORS: dict[Integrator, Step] = {
    Integrator.EXPLICIT_EULER: explicit_euler,
    Integrator.SEMI_IMPLICIT_EULER: semi_implicit_euler,
    Integrator.TRAPEZOID: trapezoid,
    Integrator.VERLET: verlet,
    Integrator.RK2: rk2,
    Integrator.RK4: rk4,
    Integrator.EXPONENTIAL: exponential,
}

ORDERS: dict[Integrator, int] = {
    Integrator.EXPLICIT_EULER: 1,
    Integrator.SEMI_IMPLICIT_EULER: 1,
    Integrator.TRAPEZOID: 1,
    Integrator.VERLET: 2,
    Integrator.RK2: 2,
    Integrator.RK4: 4,
    Integrator.EXPONENTIAL: 1,
}
