"""What one call of each shader arithmetic function costs, native against portable, and
what the float32 numpy twin costs per element (docs/numerics.md, "Portable arithmetic").

`python -m cavesim.tools.bench.arithmetic_cost` prints the table. A call is timed inside the
probe shader (probes/arithmetic.glsl, REPEAT calls per invocation on operands one ULP
apart); the loop alone, timed with native f_ftz (the identity), is subtracted.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import moderngl
import numpy as np

from cavesim.gpu.gl.arithmetic_probe import TWINS, time_calls
from cavesim.gpu.gl.context import create_context, describe

TIMED = ("f_add", "f_mul", "f_ftz", "f_div", "f_sqrt", "f_exp", "f_log", "f_pow", "f_sin",
         "f_cos", "f_mix", "f_dot vec3", "f_length vec3", "f_normalize vec3")
TWIN_ELEMENTS = 300_000  # a CI scene's particle count


@dataclass(frozen=True)
class CallCost:
    function: str
    native_ns: float  # per call, on the GL context
    portable_ns: float
    twin_ns: float  # per element, the numpy twin on TWIN_ELEMENTS


def call_costs(ctx: moderngl.Context, functions: tuple[str, ...] = TIMED,
               cases: int = 2**16, repeat: int = 128,
               twin_elements: int = TWIN_ELEMENTS) -> list[CallCost]:
    """The cost of each function in `functions` (arithmetic_probe.FUNCTIONS names)."""
    # in every function's domain, and still after `repeat` steps of one ULP
    operands = np.random.default_rng(0).uniform(0.5, 2.0, (cases, 3, 3)).astype(np.float32)
    calls = cases * repeat
    loop = time_calls(ctx, "f_ftz", operands, "native", repeat, runs=9)
    costs = []
    for function in functions:
        native, portable = (time_calls(ctx, function, operands, mode, repeat, runs=5) - loop
                            for mode in ("native", "portable"))
        costs.append(CallCost(function, max(native, 0.0) / calls * 1e9,
                              max(portable, 0.0) / calls * 1e9,
                              _twin_seconds(function, twin_elements) / twin_elements * 1e9))
    return costs


def _twin_seconds(function: str, elements: int) -> float:
    # one contiguous array per operand component, as a vectorized caller holds them
    operands = np.random.default_rng(1).uniform(0.5, 2.0, (3, 3, elements)).astype(
        np.float32).transpose(2, 0, 1)
    call = TWINS[function]
    call(*operands.transpose(1, 0, 2))  # warm
    start = time.perf_counter()
    call(*operands.transpose(1, 0, 2))
    return time.perf_counter() - start


def table(costs: list[CallCost]) -> str:
    """Markdown, one row per function."""
    rows = ["| function | native ns/call | portable ns/call | portable/native | "
            "numpy twin ns/element |", "|---|---:|---:|---:|---:|"]
    for cost in costs:
        ratio = f"{cost.portable_ns / cost.native_ns:.0f}x" if cost.native_ns >= 0.05 else "-"
        rows.append(f"| `{cost.function}` | {cost.native_ns:.2f} | {cost.portable_ns:.2f} | "
                    f"{ratio} | {cost.twin_ns:.1f} |")
    return "\n".join(rows)


def main() -> None:
    ctx = create_context()
    print(f"{describe(ctx)['renderer']}")
    print(table(call_costs(ctx)))


if __name__ == "__main__":
    main()
