"""`cavesim bench`: throughput of the GS/TF step against its numpy twin and compute bound.

`run_bench` measures every size on one GL context and writes `bench.json` (machine-readable
first, see DESIGN "Reports") and `bench.md` next to the table it prints.
"""

from cavesim.tools.bench.figures import TARGETS, SizeFigures, Target
from cavesim.tools.bench.measure import BenchError
from cavesim.tools.bench.runner import run_bench

__all__ = ["TARGETS", "BenchError", "SizeFigures", "Target", "run_bench"]
