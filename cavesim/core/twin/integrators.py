"""One step of each integrator: (p, v, h, forces) -> (p, v).

Twin of `integrate` in shaders/include/physics.glsl; `INTEGRATORS` maps the scene's
choice to the function of its name (the `Integrator` table holds the rest of each method).
"""

from __future__ import annotations

import math
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
    f, lam, _ = forces.linear_parts(p, v)
    v = v + (h / (1 + h * lam)) * (f - lam * v)  # = (v + h f) / (1 + h lambda), as an increment
    return p + h * v, v


def trapezoid(p, v, h, forces):
    """UberFlow eq. (1)-(2): Euler velocity, trapezoidal position, order 1."""
    v1 = v + h * forces.acceleration(p, v)
    return p + (0.5 * h) * (v + v1), v1


def verlet(p, v, h, forces):
    """Velocity Verlet with an Euler-predicted velocity for the drag, order 2."""
    a0 = forces.acceleration(p, v)
    p = p + h * (v + (0.5 * h) * a0)
    a1 = forces.acceleration(p, v + h * a0)
    return p, v + (0.5 * h) * (a0 + a1)


def runge_kutta_stages(p, v, h, a_rows, forces, kp=(), kv=()):
    """The stages (kp, kv lists) of an explicit Runge-Kutta tableau's rows `a_rows`, after
    the stages already given (an embedded pair's first stage, reused from the last step)."""
    kp, kv = list(kp), list(kv)
    for row in a_rows:
        ps, vs = p, v
        for coefficient, dp, dv in zip(row, kp, kv, strict=False):
            if coefficient:
                ps = ps + (coefficient * h) * dp
                vs = vs + (coefficient * h) * dv
        kp.append(vs)
        kv.append(forces.acceleration(ps, vs))
    return kp, kv


def _explicit_runge_kutta(a_table, b_weights) -> Step:
    def step(p, v, h, forces):
        kp, kv = runge_kutta_stages(p, v, h, a_table, forces)
        dp = sum(w * k for w, k in zip(b_weights, kp, strict=True) if w)
        dv = sum(w * k for w, k in zip(b_weights, kv, strict=True) if w)
        return p + h * dp, v + h * dv

    return step


rk2 = _explicit_runge_kutta(RK2_MIDPOINT_A, RK2_MIDPOINT_B)
rk2.__doc__ = "Explicit midpoint Runge-Kutta, order 2."
rk4 = _explicit_runge_kutta(RK4_CLASSIC_A, RK4_CLASSIC_B)
rk4.__doc__ = "Classic Runge-Kutta, order 4."


SERIES_BELOW = 1.0  # x below which the phi functions are summed as their Taylor series
SERIES_TERMS = 18  # x^17 / 18! < 2e-16: the series is exact to float64 below SERIES_BELOW


def _phi_series(x: np.ndarray, k: int) -> np.ndarray:
    """phi_k(-x) = sum_j (-x)^j / (j + k)!, by Horner; exact to float64 for 0 <= x < 1."""
    total = np.zeros_like(x)
    for j in reversed(range(SERIES_TERMS)):
        total = 1.0 / math.factorial(j + k) - x * total
    return total


def exponential_weights(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """e^-x, phi1 = (1 - e^-x)/x and phi2 = (x - 1 + e^-x)/x^2, accurate for all x >= 0.

    phi_k(x) here is phi_k(-x) of Hochbruck & Ostermann (2010), Acta Numerica 19, 209-286:
    the weights of the exact solution of dv/dt = f - x/h v over a step h.
    """
    series = x < SERIES_BELOW
    xs = np.where(series, 1.0, x)
    em1 = np.expm1(-xs)
    phi1 = np.where(series, _phi_series(x, 1), -em1 / xs)
    phi2 = np.where(series, _phi_series(x, 2), (xs + em1) / (xs * xs))
    return np.exp(-x), phi1, phi2


def phi3_weight(x: np.ndarray, phi2: np.ndarray) -> np.ndarray:
    """phi3 = (x^2/2 - x + 1 - e^-x)/x^3 = (1/2 - phi2)/x, the series below SERIES_BELOW
    (where the recurrence cancels)."""
    series = x < SERIES_BELOW
    return np.where(series, _phi_series(x, 3), (0.5 - phi2) / np.where(series, 1.0, x))


def exponential(p, v, h, forces):
    """Exponential Euler: exact for linear drag with the flow held over the step; stable for
    any tau/h, order 1. In increment form (r is the acceleration at the start; e^-x never
    enters, so nothing cancels in 1 - e^-x at small h) with the position moved in one
    addition: float32 keeps its floor at every dt."""
    f, lam, _ = forces.linear_parts(p, v)
    _, phi1, phi2 = exponential_weights(lam * h)
    r = f - lam * v
    return p + h * (v + (h * phi2) * r), v + (h * phi1) * r


def etd2rk(p, v, h, forces):
    """ETD2RK of Cox & Matthews (2002), J. Comput. Phys. 176, 430-455, order 2, for
    dv/dt = F(p) - lambda v, dp/dt = v, with F(p) = (u(p) + u_t) lambda_d + g and lambda =
    lambda_d + k, the drag rate lambda_d held at its value at the start (1/tau for Stokes
    drag; Schiller-Naumann's from the slip there).

    The linear part, drag and dp/dt = v, is integrated exactly; F is interpolated linearly
    in time between its value at the start and at the exponential-Euler predicted position
    pa (two flow evaluations per step, like RK2). With x = lambda h, r = F(p) - lambda v and
    d = F(pa) - F(p):
        pa = p + h (v + h phi2 r)
        p' = p + h (v + h phi2 r + h phi3 d)
        v' = v + h (phi1 r + phi2 d)
    (the velocity is Cox & Matthews' ETD2RK; the position is the same quadrature of the
    exact solution, integrated once more: phi_k -> phi_k+1). Exact wherever F is constant
    along the path (uniform flow), stable for any h/tau (the stiff part is never stepped
    explicitly); its stiff order is 2 (Hochbruck & Ostermann 2005, SIAM J. Numer. Anal. 43,
    1069-1090: the conditions b1 + b2 = phi1, b2 c2 = phi2 hold with c2 = 1).
    """
    f, lam, drag = forces.linear_parts(p, v)
    x = lam * h
    _, phi1, phi2 = exponential_weights(x)
    phi3 = phi3_weight(x, phi2)
    r = f - lam * v
    w = v + (h * phi2) * r
    d = forces.forcing(p + h * w, drag) - f
    return p + h * (w + (h * phi3) * d), v + h * (phi1 * r + phi2 * d)


# Each integrator's step is the function above named as its scene file names it.
INTEGRATORS: dict[Integrator, Step] = {i: globals()[i.value] for i in Integrator}
