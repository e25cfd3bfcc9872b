"""`cavesim accuracy`: observed orders against the METHODS table, the GPU against its float64
twin, and the files the command writes.

One quick run (every case and integrator, dt = 1/15 ... 1/240 s, 2,000 particles) on the
session's GL context feeds every GL test here.
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest
from rich.console import Console

from cavesim.core.scene.model import Integrator
from cavesim.core.twin.integrators import ORDERS
from cavesim.tools.arguments import REPO_ROOT
from cavesim.tools.cli import main
from cavesim.tools.numerics import METHODS, QUICK_DTS, run_command
from cavesim.tools.numerics.cases import HELICOPTER_SCENE, QUICK_PARTICLES, REPORT_DT, uniform_case
from cavesim.tools.numerics.methods import EXACT_TOLERANCE
from cavesim.tools.numerics.order import MIN_FIT_POINTS, observed_order
from cavesim.tools.numerics.reference import closed_form

SMOOTH_CASES = ("uniform", "vortex")
FLOAT32_FLOOR = 1e-4  # m: what float32 arithmetic may add to a GPU error over T = 1 s
GPU_TO_TWIN_FACTOR = 2.0


@pytest.fixture(scope="module")
def quick_run(gl_session, tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy")
    console = Console(file=io.StringIO(), width=200)
    result = run_command(REPO_ROOT / HELICOPTER_SCENE, out, console, quick=True,
                         ctx=gl_session)
    return result, out, console.file.getvalue()


def summary_of(result, case: str, method):
    [summary] = [s for s in result.summaries
                 if s.case == case and s.integrator == method.name]
    return summary


def test_the_table_has_every_integrator_with_the_twins_order():
    assert [m.integrator for m in METHODS] == list(Integrator)
    for method in METHODS:
        assert method.order == ORDERS[method.integrator]
        assert method.tolerance == 0.3
    exact = {m.name: sorted(m.exact_in) for m in METHODS if m.exact_in}
    assert exact == {"exponential": ["uniform"], "etd2rk": ["uniform"]}


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
@pytest.mark.parametrize("case", SMOOTH_CASES)
def test_observed_order_matches_the_table(quick_run, case, method):
    result, _, _ = quick_run
    summary = summary_of(result, case, method)
    if method.is_exact(case):
        assert summary.twin_max_error < EXACT_TOLERANCE, summary
        assert summary.verdict == "exact"
        return
    order_limit = {c["name"]: c["order_limit"] for c in result.report["cases"]}[case]
    expected = method.expected_order(order_limit)
    assert len(summary.fit_dts) >= MIN_FIT_POINTS
    assert abs(summary.observed - expected) <= method.tolerance, (
        f"{method.name} in {case}: observed order {summary.observed:.2f}, expected {expected}")
    assert summary.verdict == "ok"


def test_only_rk4_is_capped_by_the_trilinear_grid(quick_run):
    result, _, _ = quick_run
    capped = [s.integrator for s in result.summaries
              if s.expected is not None and s.expected < s.order]
    assert capped == ["rk4"]
    assert [s.case for s in result.summaries if s.integrator == "rk4" and s.expected == 2] \
        == ["vortex"]


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


def test_the_error_sources_are_kept_apart(quick_run):
    result, _, _ = quick_run
    for row in result.rows:
        assert all(math.isfinite(x) and x >= 0 for x in (
            row.gpu_rms, row.gpu_max, row.twin_rms, row.twin_max, row.float32_rms))
        assert row.gpu_max >= row.gpu_rms and row.twin_max >= row.twin_rms
        # the GPU's error is the twin's plus float32: the triangle inequality bounds it
        assert row.gpu_rms <= row.twin_rms + row.float32_rms + 1e-12
        filtered = row.case == "vortex"
        assert math.isfinite(row.filtering_rms) == filtered, row
        if filtered:
            assert row.filtering_rms < 1e-2
        assert row.gpu_step_ms > 0 and row.gpu_run_s > 0


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


def test_the_command_writes_csv_markdown_json_and_png(quick_run, ctx):
    result, out, printed = quick_run
    names = ("accuracy.csv", "accuracy.md", "accuracy.json", "work_precision.png")
    assert result.paths == [out / name for name in names]
    for name in names:
        assert f"wrote {out / name}" in printed
    with (out / "accuracy.csv").open(newline="") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 3 * len(METHODS) * len(QUICK_DTS)
    assert {r["dt_label"] for r in rows} == {"1/15", "1/30", "1/60", "1/120", "1/240"}
    report = json.loads((out / "accuracy.json").read_text())
    assert report["command"] == "accuracy" and report["particles"] == QUICK_PARTICLES
    assert len(report["summary"]) == 3 * len(METHODS)
    assert [c["name"] for c in report["cases"]] == ["uniform", "vortex", "downwash"]
    text = (out / "accuracy.md").read_text()
    for heading in ("## uniform", "## vortex", "## downwash", "observed (f64)", "portable cost"):
        assert heading in text
    assert all(f"| {m.name} |" in text for m in METHODS)
    png = (out / "work_precision.png").read_bytes()
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
    late = closed_form(case, 60.0)  # 120 relaxation times
    u, g, tau = np.array([3.0, -1.0, 0.5]), np.array([0.0, 0.0, -9.81]), 0.5
    np.testing.assert_allclose(late.vel, np.broadcast_to(u + g * tau, late.vel.shape),
                               rtol=1e-6)


@pytest.mark.parametrize("argv, flag", [
    (["accuracy", "--particles", "0"], "--particles"),
    (["accuracy", "--scene", "config/scenes/bench.toml"], "--scene"),
])
def test_bad_flags_end_with_a_usage_error(capsys, argv, flag):
    assert main(argv) == 2
    message = capsys.readouterr().err
    assert flag in message and "Traceback" not in message
