"""`run_accuracy`: every integrator, every dt, every case - on the GPU, then in float64.

The GPU runs come first and alone, so their step times are not shared with the numpy work;
the float64 work (twin runs, fine references, the Dormand-Prince tolerance sweep) then runs
in worker processes, one job per case and integrator or tolerance, the references split
by particles (which never interact).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

import moderngl
import numpy as np
from rich.console import Console

from cavesim.core.scene.model import Motion
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.numerics.cases import (
    DTS,
    FINAL_TIME,
    PARTICLES,
    QUICK_DTS,
    QUICK_PARTICLES,
    REPORT_DT,
    Case,
    build_cases,
)
from cavesim.tools.numerics.display import progress_bar, show
from cavesim.tools.numerics.methods import METHODS, Method
from cavesim.tools.numerics.reference import (
    CLOSED_FORMS,
    REFINEMENT,
    TOLERANCES,
    Reference,
    adaptive,
    concatenate,
    fine_rk4,
)
from cavesim.tools.numerics.report import build_report, write_outputs
from cavesim.tools.numerics.results import Row, Summary, make_rows, summarize
from cavesim.tools.numerics.runs import (
    HARDWARE,
    MANUAL,
    PORTABLE,
    GpuVariant,
    Run,
    gpu_runs,
    twin_runs,
)
from cavesim.tools.numerics.tolerance_sweep import (
    ReferenceAccuracy,
    SweepRow,
    reference_accuracy,
    smallest_fitted_error,
    sweep_rows,
)

MAX_WORKERS = 4


@dataclass(frozen=True)
class AccuracyResult:
    rows: list[Row]
    summaries: list[Summary]
    sweep: list[SweepRow]  # every case, every tolerance
    reference_accuracy: list[ReferenceAccuracy]  # the cases without a closed form
    report: dict[str, object]
    paths: list[Path]


def run_command(helicopter_scene: Path, out_dir: Path, console: Console,
                particles: int | None = None, quick: bool = False,
                ctx: moderngl.Context | None = None, workers: int | None = None
                ) -> AccuracyResult:
    """`cavesim accuracy`: the cases with `particles` each (default: PARTICLES, or
    QUICK_PARTICLES with `quick`) over DTS (QUICK_DTS with `quick`).

    Opens (and releases) its own GL context unless one is given; a count the context
    cannot hold is a CapacityError before any case is built.
    """
    count = particles or (QUICK_PARTICLES if quick else PARTICLES)
    own_context = ctx is None
    ctx = create_context() if own_context else ctx
    try:
        capacity_limits(ctx.info).check(count)
        with tempfile.TemporaryDirectory(prefix="cavesim-accuracy-") as field_dir:
            return run_accuracy(build_cases(helicopter_scene, count, Path(field_dir)),
                                QUICK_DTS if quick else DTS, out_dir, console, ctx, workers)
    finally:
        if own_context:
            ctx.release()


def run_accuracy(cases: list[Case], dts: tuple[float, ...], out_dir: Path, console: Console,
                 ctx: moderngl.Context, workers: int | None = None,
                 final_time: float = FINAL_TIME) -> AccuracyResult:
    """Measure on `ctx`, print the table, write accuracy.csv/.md/.json and work_precision.png.

    `workers` float64 processes (default: one per CPU; 1 runs them in this process).
    """
    if REPORT_DT not in dts:
        raise ValueError(f"dts must include the report dt {REPORT_DT!r}, got {dts=!r}")
    uneven = [dt for dt in dts if not math.isclose(final_time / dt, round(final_time / dt))]
    if uneven:
        raise ValueError(f"every dt must divide final_time={final_time!r} into whole steps "
                         f"(the references are carried only a float32 rounding's time to each "
                         f"run's end), got {uneven=!r}")
    workers = workers or min(os.cpu_count() or 1, MAX_WORKERS)
    gl = describe(ctx)
    jobs = _float64_jobs(cases, dts, final_time, workers)
    gpu_total = sum(len(dts) * len(_methods(c)) * len(_variants(c)) for c in cases)
    with progress_bar(console) as progress:
        task = progress.add_task("accuracy", total=gpu_total + len(jobs))

        def tick(what: str) -> None:
            progress.update(task, advance=1, description=what)

        gpu = _gpu_phase(ctx, cases, dts, final_time, tick)
        done = _run_jobs(jobs, workers, tick)
    rows, summaries, sweep, accuracies = _evaluate(cases, gpu, done, final_time)
    report = build_report(cases, dts, final_time, summaries, sweep, accuracies, gl, workers)
    show(report, summaries, sweep, accuracies, console)
    paths = write_outputs(report, rows, summaries, sweep, accuracies, out_dir)
    for path in paths:
        console.print(f"wrote {path}", markup=False, highlight=False, soft_wrap=True)
    return AccuracyResult(rows, summaries, sweep, accuracies, report, paths)


def _methods(case: Case) -> list[Method]:
    """The rows of METHODS the case is measured with."""
    return [m for m in METHODS if m.integrator in case.integrators]


def _variants(case: Case) -> list[GpuVariant]:
    """Manual trilinear and portable arithmetic always, hardware filtering where asked."""
    return [MANUAL, PORTABLE] + ([HARDWARE] if case.filtering else [])


def _gpu_phase(ctx: moderngl.Context, cases: list[Case], dts: tuple[float, ...],
               final_time: float, tick: Callable[[str], None]
               ) -> dict[tuple[str, str, str], list[Run]]:
    """GPU runs by (case, integrator, variant name)."""
    runs = {}
    for case in cases:
        for method in _methods(case):
            for variant in _variants(case):
                label = f"GPU {case.name} {method.name} ({variant.name})"
                runs[case.name, method.name, variant.name] = gpu_runs(
                    ctx, case, method.integrator, variant, dts, final_time,
                    lambda label=label: tick(label))
    return runs


@dataclass(frozen=True)
class _Job:
    key: tuple[str, ...]  # ("twin", case, integrator), ("reference", case, chunk) or
    #                       ("adaptive", case, tolerance)
    function: Callable
    args: tuple


def _float64_jobs(cases: list[Case], dts: tuple[float, ...], final_time: float,
                  workers: int) -> list[_Job]:
    """References first, one chunk of particles per worker: they are the longest jobs; then
    the sweep, the loosest tolerance last (the shortest)."""
    jobs = []
    step = min(dts) / REFINEMENT
    for case in cases:
        if not case.closed_form:
            bounds = np.linspace(0, len(case.particles), workers + 1).astype(int)
            jobs += [_Job(("reference", case.name, str(k)), fine_rk4,
                          (case.subset(slice(a, b)), final_time, step))
                     for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True))
                     if b > a]
    # Dormand-Prince's stage times need a steady field, and it steps inertial particles
    swept = [c for c in cases if c.snapshot_steps is None and c.motion is Motion.INERTIAL]
    for tolerance in sorted(TOLERANCES):
        jobs += [_Job(("adaptive", case.name, f"{tolerance:g}"), adaptive,
                      (case, final_time, tolerance)) for case in swept]
    for case in cases:
        jobs += [_Job(("twin", case.name, m.name), twin_runs,
                      (case, m.integrator, dts, final_time)) for m in _methods(case)]
    return jobs


def _run_jobs(jobs: list[_Job], workers: int,
              tick: Callable[[str], None]) -> dict[tuple[str, ...], object]:
    def label(job: _Job) -> str:
        kind, case, what = job.key
        return {"twin": f"float64 {case} {what}", "reference": f"float64 {case} reference",
                "adaptive": f"float64 {case} Dormand-Prince tol {what}"}[kind]

    if workers == 1:
        done = {}
        for job in jobs:
            done[job.key] = job.function(*job.args)
            tick(label(job))
        return done
    # spawn, not fork: this process runs llvmpipe's threads, and a forked child keeps none
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(job.function, *job.args): job for job in jobs}
        done = {}
        for future in as_completed(futures):
            job = futures[future]
            done[job.key] = future.result()
            tick(label(job))
        return done


def _reference(case: Case, done, final_time: float) -> Reference:
    if case.closed_form:
        return CLOSED_FORMS[case.closed_form](case, final_time)
    parts = sorted((int(k[2]), r) for k, r in done.items()
                   if k[0] == "reference" and k[1] == case.name)
    return concatenate([r for _, r in parts])


def _evaluate(cases: list[Case], gpu: dict, done: dict, final_time: float
              ) -> tuple[list[Row], list[Summary], list[SweepRow], list[ReferenceAccuracy]]:
    rows, summaries, sweep, accuracies = [], [], [], []
    for case in cases:
        reference = _reference(case, done, final_time)
        scale = float(np.sqrt(np.mean(np.sum(reference.pos**2, axis=1))))
        case_rows, case_summaries = [], []
        for method in _methods(case):
            hardware = gpu.get((case.name, method.name, HARDWARE.name))
            method_rows = make_rows(case, method, reference,
                                    gpu[case.name, method.name, MANUAL.name],
                                    done["twin", case.name, method.name], hardware,
                                    gpu[case.name, method.name, PORTABLE.name], scale)
            case_rows += method_rows
            case_summaries.append(summarize(case, method, method_rows, REPORT_DT))
        states = [r for k, r in done.items() if k[0] == "adaptive" and k[1] == case.name]
        case_sweep = sweep_rows(case.name, reference, states)
        if not case.closed_form:
            accuracies.append(reference_accuracy(
                case_sweep, smallest_fitted_error(case.name, case_rows, case_summaries)))
        rows += case_rows
        summaries += case_summaries
        sweep += case_sweep
    return rows, summaries, sweep, accuracies
