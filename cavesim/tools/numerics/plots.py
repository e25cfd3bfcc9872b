"""The work-precision plots: GPU RMS error against the cost of reaching T, log-log, one panel
per case; the cost is GPU run time (work_precision.png, this renderer's) or field
evaluations per particle (work_precision_evaluations.png, any hardware's)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: no display, no GUI event loop
import matplotlib.pyplot as plt  # noqa: E402  (must follow the backend choice)

from cavesim.tools.numerics.methods import METHODS  # noqa: E402
from cavesim.tools.numerics.results import Row  # noqa: E402

FLOOR = 1e-16  # m: where an error of 0 is drawn on the log axis


@dataclass(frozen=True)
class Cost:
    label: str  # of the x axis
    of: Callable[[Row], float]


RUN_TIME = Cost("GPU run time to T (s)", lambda r: r.gpu_run_s)
EVALUATIONS = Cost("field evaluations per particle to T", lambda r: r.evaluations)


def work_precision(rows: list[Row], cases: list[str], cost: Cost, path: Path) -> None:
    figure, axes = plt.subplots(1, len(cases), figsize=(5.2 * len(cases), 4.6), squeeze=False)
    for ax, case in zip(axes[0], cases, strict=True):
        for method in METHODS:
            line = sorted((r for r in rows if r.case == case and r.integrator == method.name),
                          key=lambda r: -r.dt)
            if not line:
                continue
            x = [cost.of(r) for r in line]
            y = [max(r.gpu_rms, FLOOR) for r in line]
            ax.loglog(x, y, marker="o", markersize=3, linewidth=1.2, label=method.name)
            for r, xi, yi in ((line[0], x[0], y[0]), (line[-1], x[-1], y[-1])):
                ax.annotate(r.dt_label, (xi, yi), fontsize=6, textcoords="offset points",
                            xytext=(3, 3))
        ax.set_title(case)
        ax.set_xlabel(cost.label)
        ax.grid(True, which="major", linewidth=0.4, alpha=0.5)
    axes[0][0].set_ylabel("GPU RMS position error (m)")
    axes[0][0].legend(fontsize=7, loc="best")  # the first case runs every method
    figure.suptitle("work-precision: dt from 1/15 s (left) halving to the finest (right)",
                    fontsize=9)
    figure.tight_layout()
    figure.savefig(path, dpi=130)
    plt.close(figure)
