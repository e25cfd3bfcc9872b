"""Accuracy of the integrators: error against run time on the GPU and against field
evaluations, with the float64 twin.

`cavesim accuracy` runs every integrator of `METHODS` (the one table of method, order,
tolerance and field evaluations per step that the tests read too) over a range of dts in
the cases of `cases.py`, checks the float64 reference with Dormand-Prince 5(4) at a sweep
of tolerances (`sweep.py`), and writes accuracy.csv, accuracy.md, accuracy.json,
work_precision.png and work_precision_evaluations.png.
"""

from cavesim.tools.numerics.accuracy import AccuracyResult, run_accuracy, run_command
from cavesim.tools.numerics.cases import DTS, QUICK_DTS, Case, build_cases
from cavesim.tools.numerics.methods import METHODS, Method

__all__ = ["DTS", "METHODS", "QUICK_DTS", "AccuracyResult", "Case", "Method", "build_cases",
           "run_accuracy",
           "run_command"]
