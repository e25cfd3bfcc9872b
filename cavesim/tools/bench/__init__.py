"""`cavesim bench`: throughput of both engine paths against the copy bound and numpy.

`run_bench` measures every size on one GL context and writes `bench.json` (machine-readable
first, see DESIGN "Reports") and `bench.md` next to the table it prints.
"""

from cavesim.tools.bench.figures import TARGETS, SizeFigures, Target
from cavesim.tools.bench.measure import BenchError
from cavesim.tools.bench.runner import run_bench

__all__ = ["TARGETS", "BenchError", "SizeFigures", "Target", "run_bench"]
