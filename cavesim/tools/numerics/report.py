"""The accuracy files: accuracy.csv (every run), accuracy.md and accuracy.json (the summary,
the reference check) and the work-precision plots against run time and field evaluations.
Table cells are built once here; the terminal shows the same cells.
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

from cavesim.core.scene.model import Integrator, Motion
from cavesim.tools.numerics import order as order_rule
from cavesim.tools.numerics.cases import HELD_ORDER_TOLERANCE, REPORT_DT, TAU, Case
from cavesim.tools.numerics.cloud import CLOUD_CELL
from cavesim.tools.numerics.methods import FORGOTTEN_TOLERANCE, METHODS
from cavesim.tools.numerics.reference import REFINEMENT, TOLERANCES
from cavesim.tools.numerics.results import Row, Summary, dt_label
from cavesim.tools.numerics.tolerance_sweep import ReferenceAccuracy, SweepRow

HEADERS = ("integrator", "order", "expected", "observed (f64)", "fit over", "verdict",
           "evals per step", "GPU RMS (m)", "GPU max (m)", "f64 RMS (m)", "GPU vel RMS (m/s)",
           "GPU vel max (m/s)", "f64 vel RMS (m/s)", "GPU cloud", "f64 cloud",
           "float32 floor (m)", "filtering (m)", "GPU ms/step", "GPU ns/particle",
           "hw-filter ms/step", "portable RMS (m)", "portable vs native (m)",
           "portable ms/step", "portable cost")
SWEEP_HEADERS = ("tolerance", "steps (mean)", "steps (max)", "rejected (mean)",
                 "evals/particle", "RMS vs reference (m)", "max (m)", "vel RMS (m/s)",
                 "RMS vs tightest (m)")
NOTES = (
    "GPU = the engine in float32 with manual trilinear sampling; f64 = the numpy twin in "
    "float64 with the same method and dt (time-stepping error alone); both against the "
    "float64 reference at the run's end time",
    f"every run lasts T = {1 / TAU:g} tau (probe particles with tau = {TAU:g} s): the "
    "particles have forgotten their start and follow the flow, as the demo's cloud does",
    f"errors and costs at dt = {dt_label(REPORT_DT)} s unless said otherwise; RMS and max "
    "are over particles of the position error |x - x_ref|, vel of the velocity error "
    "|v - v_ref|",
    "evals per step = field evaluations (flow samples: a trilinear fetch or a rotor evaluation) "
    "per particle and step, from the methods table (a test counts them in the twin); the "
    "cost that does not depend on the hardware. work_precision_evaluations.png plots the "
    "GPU error against evaluations per particle to T, work_precision.png against run time",
    f"cloud = the concentration-field error (downwash, the demo's flow): final positions "
    f"deposited cloud-in-cell on {CLOUD_CELL:g} m cubes around the reference cloud, and "
    "the fraction of the cloud's mass misplaced against the reference's (half the L1 "
    "distance of the normalized densities; 0 = the same cloud, 1 = disjoint)",
    "float32 floor = RMS |GPU - f64| at the finest dt, where it is largest: float32 "
    "arithmetic and the stored state alone (the position kept to 32 bits, float32 and a "
    "byte of what it leaves out; the velocity in float32)",
    "filtering = RMS |GPU with hardware filtering - GPU with manual trilinear| (vortex only: "
    "the uniform field is exact either way, the rotor flow has no texture); filter weights "
    "are the renderer's own (many GPUs use 8-bit fixed point), so it holds for this one only",
    "expected = the order the tests hold a method to: its theoretical order, capped by the "
    "case's field (a trilinear grid is only Lipschitz: its gradient jumps at cell faces, "
    "which caps every method at order 2); '-' for the rotor downwash: its flow is smooth, "
    "but at 9.8 m/s its errors reach their asymptotic order only below 1/120 s (a full run "
    "fitted over 1/120 ... 1/960 s shows each method's order, a quick run's dts do not)",
    "forgets (uniform flow, explicit and semi-implicit Euler): every method relaxes to the "
    "exact terminal velocity, and these two also cover the transient's exact distance, so "
    "after 10 tau their error is about e^-10 of the transient's and no power of dt; held "
    f"below {FORGOTTEN_TOLERANCE:g} m instead of to an order",
    "vortex_sand, downwash_sand: the demo's 150 µm sand under Schiller-Naumann drag, whose "
    "rate follows the slip; measured with the exponential step (the rate held over the "
    f"step: order 1) and ETD2RK (order 2 for every drag law), each held within "
    f"{HELD_ORDER_TOLERANCE:g} of its order (the sand's downwash errors, unlike the probe "
    "particles', are asymptotic from 1/30 s)",
    "rotating: the uniform flow given as snapshots two steps apart, linear in time between "
    "them (each stage of a step at its own time); the closed form is the smooth turning "
    "flow, so linear interpolation's O(interval²) error caps every method at order 2, held "
    f"within {HELD_ORDER_TOLERANCE:g}",
    "reference check: Dormand-Prince 5(4) with a step of its own per particle (error per "
    "component of (p, v) held to tol (1 + |y|)) at each tolerance, against the reference at "
    "T; the reference's error is at most the RMS at the tightest tolerance plus what DP "
    "moved since the next looser one; margin = the smallest f64 error an order fit uses "
    "over that bound",
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
    if s.forgets:
        return "forgets"
    if s.expected is None:
        return "-"
    return f"{s.expected:g}" + (" (field)" if s.expected < s.order else "")  # its order_limit


def _observed(s: Summary) -> str:
    if s.exact or s.forgets:
        return f"err {s.twin_max_error:.0e}"
    return "-" if math.isnan(s.observed) else f"{s.observed:.2f}"


def _fit_range(s: Summary) -> str:
    held = not (s.exact or s.forgets) and len(s.fit_dts) > 1
    return f"{s.fit_dts[-1]}..{s.fit_dts[0]}" if held else "-"


def table_rows(summaries: list[Summary]) -> list[tuple[str, ...]]:
    """One row of display cells per summary, in HEADERS order."""
    return [(s.integrator, str(s.order), _expected(s), _observed(s), _fit_range(s), s.verdict,
             str(s.evaluations), _e(s.gpu_rms), _e(s.gpu_max), _e(s.twin_rms),
             _e(s.gpu_vel_rms), _e(s.gpu_vel_max), _e(s.twin_vel_rms), _e(s.gpu_cloud),
             _e(s.twin_cloud), _e(s.float32_floor),
             _e(s.filtering_rms), f"{s.gpu_step_ms:.3f}", f"{s.gpu_ns_per_particle:.1f}",
             "-" if math.isnan(s.hardware_step_ms) else f"{s.hardware_step_ms:.3f}",
             _e(s.portable_rms), _e(s.arithmetic_floor), f"{s.portable_step_ms:.3f}",
             f"{s.portable_cost:.2f}x") for s in summaries]


def sweep_table_rows(sweep: list[SweepRow]) -> list[tuple[str, ...]]:
    """One row of display cells per tolerance, in SWEEP_HEADERS order."""
    return [(f"{r.tolerance:.0e}", f"{r.accepted:.0f}", str(r.accepted_max),
             f"{r.rejected:.1f}", f"{r.evaluations:,.0f}", _e(r.rms), _e(r.max),
             _e(r.vel_rms), _e(r.to_tightest_rms)) for r in sweep]


def reference_sentence(accuracy: ReferenceAccuracy | None, sweep: list[SweepRow]) -> str:
    """What the sweep says about the case's reference, in one sentence."""
    if not sweep:
        return ("No Dormand-Prince check: its stages fall between the start, middle and end "
                "of a step, where a time series' field is known.")
    tightest = sweep[-1]
    if accuracy is None:
        return (f"The reference is the closed form; Dormand-Prince against it: error "
                f"{_e(tightest.rms)} m at tol {tightest.tolerance:.0e} "
                f"({tightest.accepted:.0f} steps), following the tolerance.")
    return (f"Reference error at most {_e(accuracy.bound)} m RMS (the fine RK4 against "
            f"Dormand-Prince at tol {tightest.tolerance:.0e}: {_e(accuracy.rms)} m "
            f"RMS, {_e(accuracy.max)} m max, {_e(accuracy.vel_rms)} m/s; DP moved "
            f"{_e(accuracy.dp_moved)} m since the next looser tolerance). The smallest f64 "
            f"error an order fit uses, {_e(accuracy.smallest_fitted)} m, is "
            f"{accuracy.margin:.3g} times that.")


def _reference_text(case: Case, dts: tuple[float, ...], final_time: float) -> str:
    if case.closed_form:
        return "closed form (float64)"
    step = min(dts) / REFINEMENT
    steps = max(1, round(final_time / step))
    return (f"float64 twin RK4, step {dt_label(step)} s ({steps:,} steps, "
            f"{steps * Integrator.RK4.field_evaluations:,} field evaluations per particle)")


def build_report(cases: list[Case], dts: tuple[float, ...], final_time: float,
                 summaries: list[Summary], sweep: list[SweepRow],
                 accuracies: list[ReferenceAccuracy], gl: dict[str, str], workers: int) -> dict:
    return {
        "command": "accuracy",
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "float64_workers": workers,
        "versions": {"moderngl": moderngl.__version__, "numpy": np.__version__},
        "final_time": final_time,
        "tau": TAU,
        "dts": [dt_label(dt) for dt in dts],
        "report_dt": dt_label(REPORT_DT),
        "particles": len(cases[0].particles),
        "methods": [{"integrator": m.name, "order": m.order, "tolerance": m.tolerance,
                     "evaluations": m.evaluations,
                     "tracer_method": m.integrator.tracer_method.value,
                     "tracer_order": m.order_for(Motion.TRACER),
                     "tracer_evaluations": m.evaluations_for(Motion.TRACER),
                     "exact_in": sorted(m.exact_in),
                     "forgets_in": sorted(m.forgets_in)} for m in METHODS],
        "cases": [{"name": c.name, "description": c.description, "held_to_order": c.held_to_order,
                   "motion": c.motion.value, "particles": len(c.particles),
                   "closed_form": c.closed_form,
                   "order_limit": c.order_limit, "filtering": c.filtering, "cloud": c.cloud,
                   "integrators": [i.value for i in c.integrators],
                   "order_tolerance": c.order_tolerance, "snapshot_steps": c.snapshot_steps,
                   "reference": _reference_text(c, dts, final_time)} for c in cases],
        "tolerances": sorted(TOLERANCES, reverse=True),
        "summary": [s.to_json() for s in summaries],
        "sweep": [r.to_json() for r in sweep],
        "reference_accuracy": [a.to_json() for a in accuracies],
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def _table(headers: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    return (["| " + " | ".join(headers) + " |",
             "|" + "|".join(":---" if i == 0 else "---:" for i in range(len(headers))) + "|"]
            + ["| " + " | ".join(row) + " |" for row in rows])


def markdown(report: dict, summaries: list[Summary], sweep: list[SweepRow],
             accuracies: list[ReferenceAccuracy]) -> str:
    gl = report["gl"]
    lines = [f"# cavesim accuracy - {report['particles']:,} particles to "
             f"T = {report['final_time']:g} s = {report['final_time'] / report['tau']:g} tau",
             "", f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs, dt = "
             f"{report['dts'][0]} ... {report['dts'][-1]} s, {report['created']}", ""]
    for case in report["cases"]:
        name = case["name"]
        case_sweep = [r for r in sweep if r.case == name]
        accuracy = next((a for a in accuracies if a.case == name), None)
        lines += [f"## {name}", "", f"{case['description']}; reference: "
                  f"{case['reference']}", ""]
        lines += _table(HEADERS, table_rows([s for s in summaries if s.case == name]))
        if case_sweep:
            lines += ["", f"Reference check ({name}): Dormand-Prince 5(4) against the "
                      "reference at T", ""]
            lines += _table(SWEEP_HEADERS, sweep_table_rows(case_sweep))
        lines += ["", reference_sentence(accuracy, case_sweep), ""]
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


OUTPUT_NAMES = ("accuracy.csv", "accuracy.md", "accuracy.json", "work_precision.png",
                "work_precision_evaluations.png")


def write_outputs(report: dict, rows: list[Row], summaries: list[Summary],
                  sweep: list[SweepRow], accuracies: list[ReferenceAccuracy],
                  out_dir: Path) -> list[Path]:
    """The files of OUTPUT_NAMES in `out_dir`."""
    from cavesim.tools.numerics.plots import (  # matplotlib: only when writing
        EVALUATIONS,
        RUN_TIME,
        work_precision,
    )

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / name for name in OUTPUT_NAMES]
    write_csv(rows, paths[0])
    paths[1].write_text(markdown(report, summaries, sweep, accuracies), encoding="utf-8")
    paths[2].write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    cases = [c["name"] for c in report["cases"]]
    work_precision(rows, cases, RUN_TIME, paths[3])
    work_precision(rows, cases, EVALUATIONS, paths[4])
    return paths
