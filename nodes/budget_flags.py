"""The flags that bound what one wall may cost the others, defined once for `cavesim master`,
`cavesim run` and `cavesim check`: `--max-lag` (`nodes/master/stragglers.py`) and the lag
and breach budgets (`nodes/master/budgets.py`), in either mode."""

from __future__ import annotations

import argparse

from nodes.arguments import number_in
from nodes.master.budgets import BREACH, BUDGET_RANGE, BUDGETS, LAG, Budget
from nodes.master.stragglers import DEFAULT_MAX_LAG

MAX_LAG_RANGE = (1e-3, 3600.0)  # s


def add_arguments(parser: argparse.ArgumentParser, max_lag: float = DEFAULT_MAX_LAG) -> None:
    """`--max-lag` (default `max_lag` s), `--lag-budget` and `--breach-budget`."""
    group = parser.add_argument_group(
        "stragglers and breaches", "a wall that holds the others too often is given up: out "
                                   "of the lock-step until its node joins anew")
    group.add_argument("--max-lag", type=number_in(float, *MAX_LAG_RANGE, "seconds"),
                       default=max_lag,
                       help=f"a wall whose report of a frame comes this long after half the "
                            f"walls' lags: it is named (the log, report.json's lags) and "
                            f"counted against --lag-budget; default {max_lag:g} s, half the "
                            f"default barrier timeout; on a CAVE whose GPUs keep 60 Hz, 0.1 "
                            f"(6 frames): docs/guide/running-a-cave.md")
    for name, what, which in ((LAG, "lags", "past --max-lag"),
                              (BREACH, "breaches", "divergences, or in the mixed-hardware "
                                                   "mode drifts past the tolerance")):
        budget = BUDGETS[name]
        group.add_argument(f"--{name}", type=number_in(int, *BUDGET_RANGE, what),
                           default=budget.most,
                           help=f"{what} ({which}) a wall may have in {budget.window} frames; "
                                f"one more and it is given up (default {budget.most})")


def limits_from(args: argparse.Namespace) -> dict:
    """MasterConfig's `max_lag`, `lag_budget` and `breach_budget` from the flags."""
    return {"max_lag": args.max_lag,
            "lag_budget": Budget(args.lag_budget, BUDGETS[LAG].window),
            "breach_budget": Budget(args.breach_budget, BUDGETS[BREACH].window)}
