"""The one table the accuracy tests and the error-versus-run-time report both read.

Per integrator: its theoretical order (from `cavesim.core.twin.integrators.ORDERS`, the twin's
own statement), the tolerance on the observed order, and the cases it solves exactly. A
case may cap the order any method can show (see `cases.Case.order_limit`); what the tests
hold each method to is `expected_order`.
"""

from __future__ import annotations

from dataclasses import dataclass

from cavesim.core.scene.model import Integrator
from cavesim.core.twin.integrators import ORDERS

ORDER_TOLERANCE = 0.3  # |observed - expected| allowed where the solution is smooth
EXACT_TOLERANCE = 1e-9  # m: RMS float64 error of a method in a case it solves exactly


@dataclass(frozen=True)
class Method:
    integrator: Integrator
    order: int  # theoretical order of accuracy
    tolerance: float  # on the observed order
    exact_in: frozenset[str] = frozenset()  # names of cases it solves exactly (error ~ round-off)

    @property
    def name(self) -> str:
        return self.integrator.value

    def is_exact(self, case_name: str) -> bool:
        return case_name in self.exact_in

    def expected_order(self, order_limit: float | None) -> float:
        """The order to observe in a case whose field allows at most `order_limit`."""
        return self.order if order_limit is None else min(self.order, order_limit)


# The exponential methods solve the linear part (drag, damping, dp/dt = v) exactly and
# approximate only how the forcing u(p)/tau + g changes along the path: the exponential step
# holds it, ETD2RK takes it linear in time. With a uniform flow it does not change, so both are
# the closed form itself.
EXPONENTIAL_METHODS = frozenset({Integrator.EXPONENTIAL, Integrator.ETD2RK})

METHODS: tuple[Method, ...] = tuple(
    Method(i, ORDERS[i], ORDER_TOLERANCE,
           frozenset({"uniform"}) if i in EXPONENTIAL_METHODS else frozenset())
    for i in Integrator)

