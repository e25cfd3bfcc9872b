"""`cavesim accuracy`: observed orders against the METHODS table, the GPU against its float64
twin, velocity and cloud errors, the reference check, and the files the command writes.

One quick run (every case and integrator, dt = 1/15 ... 1/240 s, 600 particles) on the
session's GL context feeds every GL test here: about a minute on 2 cores, so those
tests are marked slow, and they share one worker. What only they prove: the command end to
end, the orders observed on this GPU, and the GPU following its float64 twin.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math

import numpy as np
import pytest
from rich.console import Console

from cavesim.core.scene.model import FieldInterpolation, Integrator, Motion
from cavesim.core.substeps import DP54_A, DP54_B4, DP54_B5, DP54_C
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.tracers import TRACERS
from cavesim.tools.numerics import METHODS, QUICK_DTS, run_command
from cavesim.tools.numerics.accuracy import run_accuracy
from cavesim.tools.numerics.adaptive import dormand_prince
from cavesim.tools.numerics.cases import (
    CATMULL_ROM_ORDER_LIMIT,
    FINAL_TIME,
    HELD_ORDER_TOLERANCE,
    HELICOPTER_SCENE,
    REPORT_DT,
    ROTATING_METHODS,
    SAND_METHODS,
    TAU,
    TIME_INTERPOLATION_ORDER,
    TRACER_PARTICLES,
    rotating_case,
    rotating_tracer_case,
    smooth_vortex_case,
    tracer_case,
    uniform_case,
    vortex_case,
)
from cavesim.tools.numerics.cloud import CLOUD_CELL, CloudGrid, misplaced_fraction
from cavesim.tools.numerics.methods import EXACT_TOLERANCE, FORGOTTEN_TOLERANCE
from cavesim.tools.numerics.order import MIN_FIT_POINTS, observed_order
from cavesim.tools.numerics.reference import (
    REFINEMENT,
    TOLERANCES,
    closed_form,
    fine_rk4,
    rotating_closed_form,
    solid_body_closed_form,
    twin_forces,
)
from cavesim.tools.numerics.report import OUTPUT_NAMES
from nodes.arguments import REPO_ROOT
from nodes.cli import main

CASES = ("uniform", "vortex", "vortex_catmull_rom", "vortex_bspline", "downwash")
SAND_CASES = ("vortex_sand", "downwash_sand")  # measured with SAND_METHODS only
ROTATING = "rotating"  # a time series, measured with ROTATING_METHODS only
TRACER = "tracer"  # passive tracers: every method, held to its tracer method's order
ROTATING_TRACER = "rotating_tracer"  # tracers in the time series, ROTATING_METHODS only
SMOOTH_CASES = ("uniform", "vortex", "vortex_catmull_rom", "vortex_bspline")
FLOAT32_FLOOR = 1e-4  # m: what float32 arithmetic may add to a GPU error over T = 1 s
GPU_TO_TWIN_FACTOR = 2.0

pytestmark = pytest.mark.xdist_group("accuracy")  # one quick run, not one per worker


# the quick run's dts with fewer particles than its 2,000: a particle's error is its own
# (every order and bound here is per particle, or an RMS over them), and the run takes a
# minute instead of three
RUN_PARTICLES = 600


@pytest.fixture(scope="module")
def quick_run(gl_session, tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy")
    console = Console(file=io.StringIO(), width=200)
    result = run_command(REPO_ROOT / HELICOPTER_SCENE, out, console, RUN_PARTICLES,
                         quick=True, ctx=gl_session)
    return result, out, console.file.getvalue()


@pytest.fixture(scope="module")
def tracer_run(gl_session, tmp_path_factory):
    """The tracer cases alone over the quick dts."""
    folder = tmp_path_factory.mktemp("tracer")
    return run_accuracy([tracer_case(TRACER_PARTICLES, folder),
                         rotating_tracer_case(TRACER_PARTICLES)], QUICK_DTS, folder / "out",
                        Console(file=io.StringIO(), width=200), gl_session, workers=1)


def summary_of(result, case: str, method):
    [summary] = [s for s in result.summaries
                 if s.case == case and s.integrator == method.name]
    return summary


def test_the_table_has_every_integrator():
    assert [m.integrator for m in METHODS] == list(Integrator)
    for method in METHODS:
        assert method.tolerance == 0.3
    exact = {m.name: sorted(m.exact_in) for m in METHODS if m.exact_in}
    assert exact == {"exponential": ["uniform"], "etd2rk": ["uniform"]}
    forgets = {m.name: sorted(m.forgets_in) for m in METHODS if m.forgets_in}
    assert forgets == {"explicit_euler": ["uniform"], "semi_implicit_euler": ["uniform"]}


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_the_evaluations_column_counts_the_twins_flow_samples(method):
    """One step of the twin samples the flow exactly `evaluations` times per particle."""
    case = vortex_case(16)
    forces = twin_forces(case)
    calls = []

    def counted(p, stage):
        calls.append(len(p))
        return forces.flow(p, stage)

    p, v = case.particles["pos"].astype(float), case.particles["vel"].astype(float)
    INTEGRATORS[method.integrator](p, v, 1 / 60, dataclasses.replace(forces, flow=counted))
    assert calls == [16] * method.evaluations


def test_runs_last_ten_relaxation_times():
    scene = vortex_case(1).scene(Integrator.RK4)
    [tau] = scene.relaxation_times()
    assert tau == pytest.approx(TAU) and FINAL_TIME >= 10 * tau


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
@pytest.mark.parametrize("case", SMOOTH_CASES)
def test_observed_order_matches_the_table(quick_run, case, method):
    result, _, _ = quick_run
    summary = summary_of(result, case, method)
    if method.is_exact(case):
        assert summary.twin_max_error < EXACT_TOLERANCE, summary
        assert summary.verdict == "exact"
        return
    if method.forgets(case):
        assert summary.twin_max_error < FORGOTTEN_TOLERANCE, summary
        assert summary.verdict == "forgets" and summary.expected is None
        return
    order_limit = {c["name"]: c["order_limit"] for c in result.report["cases"]}[case]
    expected = method.expected_order(order_limit)
    assert len(summary.fit_dts) >= MIN_FIT_POINTS
    assert abs(summary.observed - expected) <= method.tolerance, (
        f"{method.name} in {case}: observed order {summary.observed:.2f}, expected {expected}")
    assert summary.verdict == "ok"


@pytest.mark.slow
def test_only_rk4_is_capped_by_the_time_series_and_the_trilinear_and_catmull_rom_grids(
        quick_run):
    result, _, _ = quick_run
    capped = [(s.case, s.integrator, s.expected) for s in result.summaries
              if s.expected is not None and s.expected < s.order]
    assert capped == [("rotating", "rk4", 2), ("vortex", "rk4", 2),
                      ("vortex_catmull_rom", "rk4", 3), ("rotating_tracer", "rk4", 2)]


@pytest.mark.slow
def test_rk4_order_rises_with_the_fields_smoothness(quick_run):
    """Trilinear (C0), Catmull-Rom (C1), B-spline (C2): RK4 observes about 2, 3, 4."""
    result, _, _ = quick_run
    rk4 = next(m for m in METHODS if m.integrator is Integrator.RK4)
    observed = [summary_of(result, case, rk4).observed
                for case in ("vortex", "vortex_catmull_rom", "vortex_bspline")]
    assert observed == sorted(observed)
    assert observed == pytest.approx([2, 3, 4], abs=rk4.tolerance)


@pytest.mark.slow
@pytest.mark.parametrize("case", SMOOTH_CASES)
def test_gpu_error_follows_the_twin_where_truncation_dominates(quick_run, case):
    result, _, _ = quick_run
    for row in result.rows:
        if row.case != case or row.dt != REPORT_DT:
            continue
        low = row.twin_rms / GPU_TO_TWIN_FACTOR - FLOAT32_FLOOR
        high = row.twin_rms * GPU_TO_TWIN_FACTOR + FLOAT32_FLOOR
        assert low <= row.gpu_rms <= high, row
        assert row.float32_rms < FLOAT32_FLOOR, row


@pytest.mark.slow
def test_the_error_sources_are_kept_apart(quick_run):
    result, _, _ = quick_run
    for row in result.rows:
        assert all(math.isfinite(x) and x >= 0 for x in (
            row.gpu_rms, row.gpu_max, row.twin_rms, row.twin_max, row.float32_rms,
            row.gpu_vel_rms, row.gpu_vel_max, row.twin_vel_rms, row.twin_vel_max))
        # the largest is at least the RMS, but for its last bit where all are equal (the
        # tracers of a uniform flow all move with it)
        for largest, rms in ((row.gpu_max, row.gpu_rms), (row.twin_max, row.twin_rms),
                             (row.gpu_vel_max, row.gpu_vel_rms),
                             (row.twin_vel_max, row.twin_vel_rms)):
            assert largest >= rms * (1 - 1e-12), row
        # the GPU's error is the twin's plus float32: the triangle inequality bounds it
        assert row.gpu_rms <= row.twin_rms + row.float32_rms + 1e-12
        filtered = row.case == "vortex"
        assert math.isfinite(row.filtering_rms) == filtered, row
        if filtered:
            assert row.filtering_rms < 1e-2
        assert row.gpu_step_ms > 0 and row.gpu_run_s > 0


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_velocity_errors_converge_at_the_methods_order(quick_run, method):
    """Velocities are read back and measured: in the vortex their float64 error falls at the
    method's order too, and the GPU's follows it."""
    result, _, _ = quick_run
    rows = [r for r in result.rows if r.case == "vortex" and r.integrator == method.name]
    fit = observed_order([r.dt for r in rows], [r.twin_vel_rms for r in rows],
                         [r.round_off_floor for r in rows])
    assert abs(fit.order - method.expected_order(2)) <= method.tolerance, fit
    for row in rows:
        assert row.gpu_vel_rms == pytest.approx(row.twin_vel_rms, rel=0.5, abs=1e-5), row


@pytest.mark.slow
def test_evaluations_to_t_are_steps_times_the_methods_count(quick_run):
    result, _, _ = quick_run
    motions = {c["name"]: Motion(c["motion"]) for c in result.report["cases"]}
    methods = {m.name: m for m in METHODS}
    for row in result.rows:
        per_step = methods[row.integrator].evaluations_for(motions[row.case])
        assert row.evaluations == row.steps * per_step > 0
    for summary in result.summaries:
        per_step = methods[summary.integrator].evaluations_for(motions[summary.case])
        assert summary.evaluations == per_step


@pytest.mark.slow
def test_cloud_error_is_measured_in_the_demo_flow_and_falls_with_dt(quick_run):
    result, _, _ = quick_run
    for row in result.rows:
        assert math.isfinite(row.gpu_cloud) == (row.case == "downwash"), row
    for method in METHODS:
        rows = sorted((r for r in result.rows
                       if r.case == "downwash" and r.integrator == method.name),
                      key=lambda r: -r.dt)
        clouds = [r.twin_cloud for r in rows]
        assert all(0 < c < 0.5 for c in clouds) and clouds == sorted(clouds, reverse=True)
        assert all(abs(r.gpu_cloud - r.twin_cloud) < 1e-3 for r in rows), rows
    cloud = {s.integrator: s.gpu_cloud for s in result.summaries if s.case == "downwash"}
    assert cloud["rk4"] < cloud["rk2"] < cloud["explicit_euler"]


def test_cloud_error_is_the_misplaced_mass():
    rng = np.random.default_rng(7)
    cloud = rng.normal(0.0, 5.0, (4000, 3))
    grid = CloudGrid.around(cloud)
    density = grid.density(cloud)
    assert density.sum() == pytest.approx(1.0)
    assert misplaced_fraction(grid, cloud, density) == pytest.approx(0.0, abs=1e-12)
    assert misplaced_fraction(grid, cloud + 1000.0, density) == pytest.approx(1.0)
    # a shift of a tenth of a cell moves about a tenth of each particle's mass per axis
    shifted = misplaced_fraction(grid, cloud + [0.1 * CLOUD_CELL, 0.0, 0.0], density)
    assert 0.02 < shifted < 0.1
    assert misplaced_fraction(grid, rng.permutation(cloud), density) == pytest.approx(0.0,
                                                                                       abs=1e-12)


def test_dormand_prince_tables_meet_the_order_conditions():
    c, b5, b4 = np.array(DP54_C), np.array(DP54_B5), np.array(DP54_B4)
    for row, ci in zip(DP54_A[1:], c[1:], strict=True):
        assert sum(row) == pytest.approx(ci)
    for k in range(5):  # quadrature conditions: sum b c^k = 1 / (k + 1)
        assert b5 @ c**k == pytest.approx(1 / (k + 1))
        if k < 4:
            assert b4 @ c**k == pytest.approx(1 / (k + 1))
    assert b4 @ c**4 != pytest.approx(1 / 5)  # the embedded one is order 4 only
    assert DP54_A[-1] == tuple(b5[:-1])  # first same as last


def test_dormand_prince_follows_its_tolerance_in_a_closed_form():
    case = uniform_case(200)
    exact = closed_form(case, FINAL_TIME)
    forces = twin_forces(case)
    errors = []
    for tolerance in (1e-6, 1e-9, 1e-12):
        run = dormand_prince(case.particles["pos"], case.particles["vel"], forces,
                             FINAL_TIME, tolerance)
        errors.append(np.abs(run.pos - exact.pos).max())
        assert errors[-1] < 10 * tolerance and np.all(run.rejected >= 0)
        assert np.all(run.evaluations == 1 + 6 * (run.accepted + run.rejected))
    assert errors == sorted(errors, reverse=True)


@pytest.mark.slow
def test_the_reference_check_converges_and_bounds_the_reference(quick_run):
    result, _, _ = quick_run
    steady = [c["name"] for c in result.report["cases"]
              if c["snapshot_steps"] is None and c["motion"] == Motion.INERTIAL]
    closed_form_apart = {ROTATING, TRACER, ROTATING_TRACER}
    assert set(steady) == {c["name"] for c in result.report["cases"]} - closed_form_apart
    assert not [r for r in result.sweep if r.case in closed_form_apart]
    for case in steady:
        sweep = [r for r in result.sweep if r.case == case]
        assert [r.tolerance for r in sweep] == sorted(TOLERANCES, reverse=True)
        steps = [r.accepted for r in sweep]
        assert steps == sorted(steps) and steps[-1] > 4 * steps[0]
        assert sweep[-1].rms < sweep[0].rms / 100, sweep
        assert sweep[-1].to_tightest_rms == 0.0
    computed = [c["name"] for c in result.report["cases"] if not c["closed_form"]]
    assert [a.case for a in result.reference_accuracy] == computed
    for accuracy in result.reference_accuracy:
        # the reference is far more accurate than any error an order is fitted to (DP's
        # bound is loose on the C1 grid, whose reference is checked by refinement below)
        assert accuracy.bound < 1e-7, accuracy
        assert accuracy.margin > 20 or accuracy.case == "vortex_catmull_rom", accuracy


@pytest.mark.slow
def test_the_c1_grids_reference_agrees_with_a_four_times_finer_one(quick_run):
    """On the Catmull-Rom grid the second derivative jumps at every cell face, which DP5(4)'s
    error estimate does not expect: its result converges slowly with the tolerance, and the
    bound it gives the reference is loose (6.6 times below the smallest fitted error, where
    the smooth cases have 60 and more). Refining the reference itself shows it is about
    1e-3 of that error (order 3: 16³ times below the finest dt's)."""
    result, _, _ = quick_run
    [accuracy] = [a for a in result.reference_accuracy if a.case == "vortex_catmull_rom"]
    case = smooth_vortex_case(100, FieldInterpolation.CATMULL_ROM, CATMULL_ROM_ORDER_LIMIT)
    step = min(QUICK_DTS) / REFINEMENT
    reference, finer = fine_rk4(case, FINAL_TIME, step), fine_rk4(case, FINAL_TIME, step / 4)
    rms = float(np.sqrt(np.mean(np.sum((reference.pos - finer.pos) ** 2, axis=1))))
    assert 0 < rms < accuracy.smallest_fitted / 100


@pytest.mark.slow
def test_portable_arithmetic_costs_time_not_accuracy(quick_run):
    """The portable GPU run differs from the native one by float32 rounding alone, and its
    step time is measured; a portable run that fell back to native would show no difference
    anywhere (its own division, sqrt and exp round differently from the built-ins)."""
    result, _, _ = quick_run
    for row in result.rows:
        assert math.isfinite(row.portable_rms) and row.portable_max >= row.portable_rms
        assert row.arithmetic_rms < FLOAT32_FLOOR, row
        assert abs(row.portable_rms - row.gpu_rms) <= row.arithmetic_rms + 1e-12, row
        assert row.portable_step_ms > 0
    downwash = [r.arithmetic_rms for r in result.rows if r.case == "downwash"]
    assert max(downwash) > 0, "the rotor flow's divisions, sqrt, exp and pow are the own ones"
    for summary in result.summaries:
        assert summary.portable_cost > 0 and summary.to_json()["portable_cost"] > 0


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_tracer_orders_match_the_tracer_methods(tracer_run, method):
    """Each integrator's tracers converge at its tracer method's order, not its own: the
    trapezoid and Verlet are order 1 and 2 with inertia, Heun's (2) without."""
    summary = summary_of(tracer_run, TRACER, method)
    expected = method.integrator.tracer_method.order
    assert summary.order == summary.expected == expected
    assert len(summary.fit_dts) >= MIN_FIT_POINTS
    assert abs(summary.observed - expected) <= method.tolerance, (
        f"{method.name} tracers: observed order {summary.observed:.2f}, expected {expected}")
    assert summary.verdict == "ok"
    assert summary.evaluations == method.integrator.tracer_method.field_evaluations


@pytest.mark.parametrize("method", [m for m in METHODS if m.integrator in ROTATING_METHODS],
                         ids=lambda m: m.name)
def test_tracers_in_a_time_series_converge_at_most_at_its_order_in_time(tracer_run, method):
    """Tracers in the turning flow's snapshots: Euler's tracers at 1, the others at the
    time interpolation's 2, RK4's too."""
    summary = summary_of(tracer_run, ROTATING_TRACER, method)
    expected = min(method.integrator.tracer_method.order, TIME_INTERPOLATION_ORDER)
    assert summary.expected == expected and len(summary.fit_dts) >= MIN_FIT_POINTS
    assert abs(summary.observed - expected) <= HELD_ORDER_TOLERANCE, summary
    assert summary.verdict == "ok"


def test_tracers_on_the_gpu_follow_the_float64_twin(tracer_run):
    """The GPU's tracer error is the twin's plus float32's, which stays below 1e-7 m."""
    rows = [r for r in tracer_run.rows if r.case == TRACER]
    assert len(rows) == len(METHODS) * len(QUICK_DTS)
    for row in rows:
        assert row.float32_rms < 1e-7 and row.arithmetic_rms < 1e-7, row
        assert row.gpu_rms <= row.twin_rms + row.float32_rms + 1e-12, row
    assert not tracer_run.sweep and not tracer_run.reference_accuracy  # closed form, no DP


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_the_tracer_evaluations_count_the_twins_tracer_flow_samples(method, tmp_path):
    case = tracer_case(16, tmp_path)
    forces = twin_forces(case)
    calls = []

    def counted(p, stage):
        calls.append(len(p))
        return forces.flow(p, stage)

    p = case.particles["pos"].astype(float)
    TRACERS[method.integrator.tracer_method](p, 1 / 60,
                                             dataclasses.replace(forces, flow=counted))
    # the last sample gives the record its velocity, the flow at the new position
    assert calls == [16] * (method.evaluations_for(Motion.TRACER) + 1)


def test_the_solid_body_closed_form_turns_the_tracers_with_the_flow(tmp_path):
    case = tracer_case(50, tmp_path)
    start = case.particles["pos"].astype(np.float64)
    quarter = solid_body_closed_form(case, np.pi / 2)
    np.testing.assert_allclose(quarter.pos[:, 0], -start[:, 1], atol=1e-12)
    np.testing.assert_allclose(quarter.pos[:, 1], start[:, 0], atol=1e-12)
    assert np.linalg.norm(start[:, :2], axis=1).max() <= 0.8
    np.testing.assert_allclose(quarter.position_at(np.pi / 2 + 1e-3),
                               solid_body_closed_form(case, np.pi / 2 + 1e-3).pos, atol=1e-9)


@pytest.mark.slow
def test_the_command_writes_csv_markdown_json_and_png(quick_run, ctx):
    result, out, printed = quick_run
    assert result.paths == [out / name for name in OUTPUT_NAMES]
    for name in OUTPUT_NAMES:
        assert f"wrote {out / name}" in printed
    assert printed.count("Reference error at most") == len(result.reference_accuracy) > 0
    with (out / "accuracy.csv").open(newline="") as file:
        rows = list(csv.DictReader(file))
    measured = ((len(CASES) + 1) * len(METHODS) + len(SAND_CASES) * len(SAND_METHODS)
                + 2 * len(ROTATING_METHODS))  # + 1: the tracer case; 2: rotating and its tracers
    assert len(rows) == measured * len(QUICK_DTS)
    assert {r["dt_label"] for r in rows} == {"1/15", "1/30", "1/60", "1/120", "1/240"}
    report = json.loads((out / "accuracy.json").read_text())
    assert report["command"] == "accuracy" and report["particles"] == RUN_PARTICLES
    assert len(report["summary"]) == measured
    # neither the time series nor the tracers are swept
    assert len(report["sweep"]) == (len(report["cases"]) - 3) * len(TOLERANCES)
    assert report["final_time"] / report["tau"] >= 10
    assert [c["name"] for c in report["cases"]] == [CASES[0], ROTATING, *CASES[1:],
                                                     *SAND_CASES, TRACER, ROTATING_TRACER]
    assert [c["particles"] for c in report["cases"]][-3:] == [RUN_PARTICLES,
                                                              TRACER_PARTICLES,
                                                              TRACER_PARTICLES]
    text = (out / "accuracy.md").read_text()
    for heading in (*(f"## {case}" for case in (*CASES, ROTATING, *SAND_CASES, TRACER,
                                                 ROTATING_TRACER)),
                    "observed (f64)",
                    "portable cost", "evals per step", "GPU vel RMS (m/s)", "GPU cloud",
                    "Reference check", "Reference error at most", "= 10 tau"):
        assert heading in text
    assert all(f"| {m.name} |" in text for m in METHODS)
    for name in ("work_precision.png", "work_precision_evaluations.png"):
        png = (out / name).read_bytes()
        assert png.startswith(b"\x89PNG") and len(png) > 10_000


def test_order_rule_fits_the_finest_points_above_round_off():
    dts = [1 / 15, 1 / 30, 1 / 60, 1 / 120, 1 / 240, 1 / 480]
    errors = [3.0 * dt**2 for dt in dts]
    fit = observed_order(dts, errors, [0.0] * len(dts))
    assert fit.order == pytest.approx(2.0) and fit.dts == tuple(dts[::-1][:4])
    floors = [1e-5 if dt < 1 / 100 else 0.0 for dt in dts]  # the finest three sink in it
    fit = observed_order(dts, errors, floors)
    assert fit.dts == (1 / 60, 1 / 30, 1 / 15) and fit.order == pytest.approx(2.0)
    assert not observed_order(dts[:2], errors[:2], [0.0, 0.0]).found


def test_closed_form_starts_at_the_particles_and_ends_at_terminal_velocity():
    case = uniform_case(50)
    start = closed_form(case, 0.0)
    np.testing.assert_array_equal(start.pos, case.particles["pos"].astype(np.float64))
    late = closed_form(case, 60 * TAU)
    u, g = np.array([3.0, -1.0, 0.5]), np.array([0.0, 0.0, -9.81])
    np.testing.assert_allclose(late.vel, np.broadcast_to(u + g * TAU, late.vel.shape),
                               rtol=1e-6)
    np.testing.assert_allclose(late.acc, 0.0, atol=1e-9)


@pytest.mark.parametrize("argv, flag", [
    (["accuracy", "--particles", "0"], "--particles"),
    (["accuracy", "--scene", "config/scenes/bench.toml"], "--scene"),
])
def test_bad_flags_end_with_a_usage_error(capsys, argv, flag):
    assert main(argv) == 2
    message = capsys.readouterr().err
    assert flag in message and "Traceback" not in message


@pytest.mark.slow
@pytest.mark.parametrize("case", ["vortex_sand", "downwash_sand"])
def test_etd2rk_is_second_order_under_schiller_naumann_drag(quick_run, case):
    """The demo's sand, whose drag rate follows the slip: ETD2RK observed at order 2 within
    0.1, the exponential step (the rate held over the step) at order 1; and the GPU follows
    its twin."""
    result, _, _ = quick_run
    etd2rk = next(m for m in METHODS if m.integrator is Integrator.ETD2RK)
    exponential = next(m for m in METHODS if m.integrator is Integrator.EXPONENTIAL)
    for method, order in ((etd2rk, 2), (exponential, 1)):
        summary = summary_of(result, case, method)
        assert summary.expected == order and summary.verdict == "ok", summary
        assert abs(summary.observed - order) <= 0.1, (case, method.name, summary.observed)
        assert summary.gpu_rms <= GPU_TO_TWIN_FACTOR * summary.twin_rms + FLOAT32_FLOOR
    assert [s.integrator for s in result.summaries if s.case == case] == [
        "exponential", "etd2rk"]


@pytest.mark.slow
@pytest.mark.parametrize("method", [m for m in METHODS if m.integrator in ROTATING_METHODS],
                         ids=lambda m: m.name)
def test_a_time_series_holds_linear_interpolations_order(quick_run, method):
    """The rotating flow given as snapshots two steps apart: against the closed form of the
    smooth turning flow, every method of order 2 or more shows order 2 within 0.1 (linear
    interpolation in time), the first-order ones 1; and the GPU follows its twin."""
    result, _, _ = quick_run
    summary = summary_of(result, "rotating", method)
    expected = min(method.order, 2)
    assert summary.expected == expected and summary.verdict == "ok", summary
    assert abs(summary.observed - expected) <= 0.1, (method.name, summary.observed)
    assert summary.gpu_rms <= GPU_TO_TWIN_FACTOR * summary.twin_rms + FLOAT32_FLOOR


def test_the_rotating_closed_form_starts_at_the_particles_and_turns_with_the_flow():
    case = rotating_case(50)
    start = rotating_closed_form(case, 0.0)
    np.testing.assert_allclose(start.pos, case.particles["pos"].astype(np.float64), atol=1e-12)
    np.testing.assert_allclose(start.vel, case.particles["vel"].astype(np.float64), atol=1e-12)
    t = 60 * TAU  # long after the start: they turn with the flow, lagging by atan(omega tau)
    late = rotating_closed_form(case, t)
    scene = case.scene(Integrator.RK4)
    omega, tau = scene.field.params["angular_speed"], scene.relaxation_times()[0]
    flow = 3.0 * np.exp(1j * omega * t)
    lagging = late.vel[:, 0] + 1j * late.vel[:, 1]
    np.testing.assert_allclose(lagging, flow / (1 + 1j * omega * tau), rtol=1e-6)
    np.testing.assert_allclose(late.vel[:, 2], 0.5 - 9.81 * tau, rtol=1e-6)
    derivative = (rotating_closed_form(case, t + 1e-6).pos - late.pos) / 1e-6
    np.testing.assert_allclose(derivative, late.vel, rtol=1e-5, atol=1e-5)


def test_each_dt_of_a_time_series_case_has_its_own_snapshots():
    case = rotating_case(4)
    for dt in (1 / 15, 1 / 240):
        times = case.scene(Integrator.RK4, dt=dt).field.times
        assert times[1] == pytest.approx(2 * dt) and times[-1] >= FINAL_TIME
        field_time = case.frame_at(case.scene(Integrator.RK4, dt=dt), 3, dt).field_time
        where = [p + w for p, w in zip(field_time.pairs, field_time.weights, strict=True)]
        assert where == pytest.approx([1.5, 1.75, 2.0], abs=1e-6)  # step 3: 3, 3.5, 4 dt
