"""The one table the accuracy tests and the error-versus-cost report both read.

Per integrator: its theoretical order and the field evaluations one step takes (the cost
that does not depend on the hardware), both from its `Integrator` row (for a tracer case,
from the row's tracer method), the tolerance on the observed order, and the cases it solves
exactly. A case may cap the order any method can show (see `cases.Case.order_limit`); what
the tests hold each method to is `expected_order`.
"""

from __future__ import annotations

from dataclasses import dataclass

from cavesim.core.scene.model import Integrator, Motion

ORDER_TOLERANCE = 0.3  # |observed - expected| allowed where the solution is smooth
EXACT_TOLERANCE = 1e-9  # m: RMS float64 error of a method in a case it solves exactly
FORGOTTEN_TOLERANCE = 1e-3  # m: RMS float64 error left of a transient after 10 tau (below)


@dataclass(frozen=True)
class Method:
    integrator: Integrator
    tolerance: float  # on the observed order
    exact_in: frozenset[str] = frozenset()  # names of cases it solves exactly (error ~ round-off)
    forgets_in: frozenset[str] = frozenset()  # cases where its error dies with the transient

    def forgets(self, case_name: str) -> bool:
        return case_name in self.forgets_in

    @property
    def name(self) -> str:
        return self.integrator.value

    @property
    def order(self) -> int:
        """Theoretical order of accuracy."""
        return self.integrator.order

    @property
    def evaluations(self) -> int:
        """Field evaluations per particle and step."""
        return self.integrator.field_evaluations

    def order_for(self, motion: Motion) -> int:
        """Theoretical order for particles that move so: a tracer's is its tracer method's."""
        return self.integrator.tracer_method.order if motion is Motion.TRACER else self.order

    def evaluations_for(self, motion: Motion) -> int:
        """Field evaluations per particle and step for particles that move so."""
        if motion is Motion.TRACER:
            return self.integrator.tracer_method.field_evaluations
        return self.evaluations

    def is_exact(self, case_name: str) -> bool:
        return case_name in self.exact_in

    def expected_order(self, order_limit: float | None,
                       motion: Motion = Motion.INERTIAL) -> float:
        """The order to observe in a case whose field allows at most `order_limit`."""
        order = self.order_for(motion)
        return order if order_limit is None else min(order, order_limit)


# The exponential methods solve the linear part (drag, damping, dp/dt = v) exactly and
# approximate only how the forcing u(p)/tau + g changes along the path: the exponential step
# holds it, ETD2RK takes it linear in time. With a uniform flow it does not change, so both
# are the closed form itself.
EXACT_IN = {Integrator.EXPONENTIAL: frozenset({"uniform"}),
            Integrator.ETD2RK: frozenset({"uniform"})}
# In a uniform flow every method relaxes to the exact terminal velocity, and explicit and
# semi-implicit Euler also move the particle the exact total distance of the transient
# (the geometric sums of their velocity decay, (1 - h/tau)^k and (1 + h/tau)^-k, add up
# to the integral of e^(-t/tau)), so after T = 10 tau their error is about e^-10 of the
# transient's distance |v0 - v_T| tau: no power of dt until dt << 2 tau²/T. The tests
# hold it below FORGOTTEN_TOLERANCE instead of to an order. Trapezoid keeps an offset
# h/2 (v_T - v0) and an order.
FORGETS_IN = {Integrator.EXPLICIT_EULER: frozenset({"uniform"}),
              Integrator.SEMI_IMPLICIT_EULER: frozenset({"uniform"})}

METHODS: tuple[Method, ...] = tuple(
    Method(i, ORDER_TOLERANCE, EXACT_IN.get(i, frozenset()), FORGETS_IN.get(i, frozenset()))
    for i in Integrator)

