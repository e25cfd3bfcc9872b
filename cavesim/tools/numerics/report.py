"""The accuracy files: accuracy.csv (every run), accuracy.md and accuracy.json (the summary)
and work_precision.png. Table cells are built once here; the terminal shows the same cells.
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path

import moderngl
import numpy as np

from cavesim.tools.numerics import order as order_rule
from cavesim.tools.numerics.cases import REPORT_DT, Case
from cavesim.tools.numerics.methods import METHODS
from cavesim.tools.numerics.reference import REFINEMENT
from cavesim.tools.numerics.results import Row, Summary, dt_label

HEADERS = ("integrator", "order", "expected", "observed (f64)", "fit over", "verdict",
           "GPU RMS (m)", "GPU max (m)", "f64 RMS (m)", "float32 floor (m)", "filtering (m)",
           "GPU ms/step", "GPU ns/particle", "hw-filter ms/step", "portable RMS (m)",
           "portable vs native (m)", "portable ms/step", "portable cost")
NOTES = (
    "GPU = the engine in float32 with manual trilinear sampling; f64 = the numpy twin in "
    "float64 with the same method and dt (time-stepping error alone); both against the "
    "float64 reference at the run's end time",
    f"errors and costs at dt = {dt_label(REPORT_DT)} s unless said otherwise; RMS and max "
    "are over particles of the position error |x - x_ref|",
    "float32 floor = RMS |GPU - f64| at the finest dt: float32 arithmetic alone, where it "
    "is largest",
    "filtering = RMS |GPU with hardware filtering - GPU with manual trilinear| (vortex only: "
    "the uniform field is exact either way, the rotor flow has no texture); filter weights "
    "are the renderer's own (many GPUs use 8-bit fixed point), so it holds for this one only",
    "expected = the order the tests hold a method to: its theoretical order, capped by the "
    "case's field (a trilinear grid is only Lipschitz: its gradient jumps at cell faces, "
    "which caps every method at order 2); '-' where the case is not smooth",
    f"observed order: least-squares slope of log(f64 RMS error) against log(dt) over the "
    f"{order_rule.FIT_POINTS} finest dts whose error exceeds {order_rule.ROUND_OFF_MARGIN:g} "
    f"times the float64 round-off n steps can accumulate (n eps |x|); fewer than "
    f"{order_rule.MIN_FIT_POINTS} such dts give no order",
    "portable = the GPU with [simulation] arithmetic = \"portable\" (own division, square "
    "root, exp, log, sin and cos from correctly rounded +, -, *, denormals flushed: the same "
    "bits on every GPU) against the reference; portable vs native = the largest RMS "
    "|portable GPU - native GPU| over the dts; cost = portable ms/step / GPU ms/step",
    "GPU ms/step is the median wall time of one ParticleSystem.step + ctx.finish(); "
    "run time to T in the plot and CSV is steps x median",
)


def _e(x: float) -> str:
    return "-" if x is None or math.isnan(x) else f"{x:.2e}"


def _expected(s: Summary) -> str:
    if s.exact:
        return "exact"
    if s.expected is None:
        return "-"
    return f"{s.expected:g}" + (" (grid)" if s.expected < s.order else "")


def _observed(s: Summary) -> str:
    if s.exact:
        return f"err {s.twin_max_error:.0e}"
    return "-" if math.isnan(s.observed) else f"{s.observed:.2f}"


def _fit_range(s: Summary) -> str:
    return f"{s.fit_dts[-1]}..{s.fit_dts[0]}" if len(s.fit_dts) > 1 else "-"


def table_rows(summaries: list[Summary]) -> list[tuple[str, ...]]:
    """One row of display cells per summary, in HEADERS order."""
    return [(s.integrator, str(s.order), _expected(s), _observed(s), _fit_range(s), s.verdict,
             _e(s.gpu_rms), _e(s.gpu_max), _e(s.twin_rms), _e(s.float32_floor),
             _e(s.filtering_rms), f"{s.gpu_step_ms:.3f}", f"{s.gpu_ns_per_particle:.1f}",
             "-" if math.isnan(s.hardware_step_ms) else f"{s.hardware_step_ms:.3f}",
             _e(s.portable_rms), _e(s.arithmetic_floor), f"{s.portable_step_ms:.3f}",
             f"{s.portable_cost:.2f}x") for s in summaries]


def _reference_text(case: Case, dts: tuple[float, ...]) -> str:
    if case.closed_form:
        return "closed form (float64)"
    return f"float64 twin RK4, step {dt_label(min(dts) / REFINEMENT)} s"


def build_report(cases: list[Case], dts: tuple[float, ...], final_time: float,
                 summaries: list[Summary], gl: dict[str, str], workers: int) -> dict:
    return {
        "command": "accuracy",
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "float64_workers": workers,
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "final_time": final_time,
        "dts": [dt_label(dt) for dt in dts],
        "report_dt": dt_label(REPORT_DT),
        "particles": len(cases[0].particles),
        "methods": [{"integrator": m.name, "order": m.order, "tolerance": m.tolerance,
                     "exact_in": sorted(m.exact_in)} for m in METHODS],
        "cases": [{"name": c.name, "description": c.description, "smooth": c.smooth,
                   "order_limit": c.order_limit, "filtering": c.filtering,
                   "reference": _reference_text(c, dts)} for c in cases],
        "summary": [s.to_json() for s in summaries],
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def markdown(report: dict, summaries: list[Summary]) -> str:
    gl = report["gl"]
    lines = [f"# cavesim accuracy - {report['particles']:,} particles to "
             f"T = {report['final_time']:g} s", "",
             f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs, dt = "
             f"{report['dts'][0]} ... {report['dts'][-1]} s, {report['created']}", ""]
    for case in report["cases"]:
        lines += [f"## {case['name']}", "", f"{case['description']}; reference: "
                  f"{case['reference']}", "",
                  "| " + " | ".join(HEADERS) + " |",
                  "|" + "|".join(":---" if i == 0 else "---:" for i in range(len(HEADERS))) + "|"]
        lines += ["| " + " | ".join(row) + " |"
                  for row in table_rows([s for s in summaries if s.case == case["name"]])]
        lines.append("")
    lines += ["## Notes", ""] + [f"- {note}" for note in report["notes"]]
    return "\n".join(lines) + "\n"


def write_csv(rows: list[Row], path: Path) -> None:
    names = [f.name for f in fields(Row)]
    with path.open("w", newline="", encoding="utf-8") as file:
        writer = csv.writer(file)
        writer.writerow(names)
        for row in rows:
            writer.writerow(["" if isinstance(v, float) and math.isnan(v) else
                             (f"{v:.9g}" if isinstance(v, float) else v)
                             for v in (getattr(row, n) for n in names)])


def write_outputs(report: dict, rows: list[Row], summaries: list[Summary],
                  out_dir: Path) -> list[Path]:
    """accuracy.csv, accuracy.md, accuracy.json and work_precision.png in `out_dir`."""
    from cavesim.tools.numerics.plots import work_precision  # matplotlib: only when writing

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / name for name in ("accuracy.csv", "accuracy.md", "accuracy.json",
                                         "work_precision.png")]
    write_csv(rows, paths[0])
    paths[1].write_text(markdown(report, summaries), encoding="utf-8")
    paths[2].write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    work_precision(rows, [c["name"] for c in report["cases"]], paths[3])
    return paths
