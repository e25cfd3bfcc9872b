"""One step of each integrator: (p, v, h, forces) -> (p, v).

Twin of `integrate` in shaders/include/integrators.glsl; `INTEGRATORS` maps the scene's
choice to the function of its name (the `Integrator` table holds the rest of each method).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from cavesim.core.fields.snapshot_time import END, STAGE_OF_FRACTION
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
    a1 = forces.acceleration(p, v + h * a0, END)
    return p, v + (0.5 * h) * (a0 + a1)


def runge_kutta_stages(p, v, h, a_rows, forces, kp=(), kv=()):
    """The stages (kp, kv lists) of an explicit Runge-Kutta tableau's rows `a_rows`, after
    the stages already given (an embedded pair's first stage, reused from the last step).
    Each stage takes the flow at its time c = sum(row) of the step: START, MIDDLE or END,
    else None (Dormand-Prince's other times: a steady flow's only)."""
    kp, kv = list(kp), list(kv)
    for row in a_rows:
        ps, vs = p, v
        for coefficient, dp, dv in zip(row, kp, kv, strict=False):
            if coefficient:
                ps = ps + (coefficient * h) * dp
                vs = vs + (coefficient * h) * dv
        kp.append(vs)
        kv.append(forces.acceleration(ps, vs, STAGE_OF_FRACTION.get(sum(row))))
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
    """ETD2RK of Cox & Matthews (2002), J. Comput. Phys. 176, 430-455, order 2 for every
    drag law.

    The split. Over one step, take lambda = lambda_0 + k, with lambda_0 the drag rate at
    the start (1/tau for Stokes drag; Schiller-Naumann's from the slip there) and k the
    damping. Then, exactly and for every (p, v),
        dv/dt = a(p, v) = N(p, v) - lambda v,   dp/dt = v,
    with N(p, v) = a(p, v) + lambda v = (u(p) + u_t) lambda_d + g - (lambda_d - lambda_0) v
    (`ForceModel.remainder`), lambda_d the drag rate at (p, v) itself. This is an identity,
    not a model: y = (p, v) solves y' = A y + (0, N(y)) with A = [[0, I], [0, -lambda I]]
    constant over the step.

    The method. ETD2RK for that system integrates the linear part exactly and takes N
    linear in time between the start and the exponential-Euler predicted state (pa, va).
    With x = lambda h, r = N(p, v) - lambda v = a(p, v) and d = N(pa, va) - N(p, v):
        pa = p + h (v + h phi2 r),  va = v + h phi1 r
        p' = p + h (v + h phi2 r + h phi3 d)
        v' = v + h (phi1 r + phi2 d)
    The velocity rows are Cox & Matthews' ETD2RK; the position rows are the same
    quadrature integrated once more (the block exponential of A turns phi_k into
    phi_k+1). Two flow evaluations per step, like RK2.

    Why order 2 for every drag law. ETD2RK is order 2 for any constant A and smooth N
    (Cox & Matthews, section 2); its stiff order is 2 when N is Lipschitz with a constant
    that does not grow with the stiffness (Hochbruck & Ostermann 2005, SIAM J. Numer.
    Anal. 43, 1069-1090: b1 + b2 = phi1, b2 c2 = phi2 with c2 = 1). The stage must be
    the whole predicted state: holding the drag rate at lambda_0 in the stage
    (d = F(pa) - F(p)) drops (lambda_d(pa, va) - lambda_0)(u - va), an O(h) change of the
    rate, and leaves a first-order method (exponential Euler in uniform flow).

    Exactness and stability. For Stokes drag lambda_d = lambda_0, so N = F(p): in uniform
    flow d = 0 and the step is the exact solution, as before. Schiller-Naumann's rate
    grows as Re^0.687, so (without turbulence) dN/dv is at most 0.687 (lambda_0 - 1/tau)
    < 0.687 lambda in size at the start; the explicit part enters v' through h phi2 <=
    1/lambda, so a perturbation of va reaches v' damped by at least 0.687: a contraction
    at any h/tau, and the stiff part is never stepped explicitly.
    """
    f, lam, drag = forces.linear_parts(p, v)
    x = lam * h
    _, phi1, phi2 = exponential_weights(x)
    phi3 = phi3_weight(x, phi2)
    r = f - lam * v
    w = v + (h * phi2) * r
    d = forces.remainder(p + h * w, v + (h * phi1) * r, drag) - f
    return p + h * (w + (h * phi3) * d), v + h * (phi1 * r + phi2 * d)


# Each integrator's step is the function above named as its scene file names it.
INTEGRATORS: dict[Integrator, Step] = {i: globals()[i.value] for i in Integrator}
