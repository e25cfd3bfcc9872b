"""Stiff and extreme cases: the outcomes match theory, and no NaN ever reaches the state."""

import math

import numpy as np
import pytest

from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator
from cavesim.tools.stability.extremes import run_extremes
from cavesim.tools.stability.sweep import (
    DRAG_CASES,
    STABILITY_LIMITS,
    STEPS,
    TAUS,
    DragCase,
    outcome_row,
    run_sweep,
)


@pytest.fixture(scope="module")
def sweep(gl_session):
    return run_sweep(gl_session)


def test_every_stiff_outcome_matches_theory(sweep):
    assert len(sweep) == len(DRAG_CASES) * len(Integrator) * len(STEPS) * len(TAUS)
    stokes = [r for r in sweep if r["drag"] == "stokes"]
    assert len(stokes) == 238 + 34  # the seven older integrators' 238, and ETD2RK's
    disagreements = [r for r in sweep if not r["agrees"]]
    assert not disagreements, disagreements[:3]
    assert all(r["state_finite"] for r in sweep), "no NaN or Inf in the GPU state"


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_each_integrator_is_bounded_exactly_below_its_limit(sweep, integrator):
    limit = STABILITY_LIMITS[integrator]
    for row in (r for r in sweep if r["integrator"] == integrator.value):
        assert (row["outcome"] == "bounded") == (row["stiffness"] < limit), row
    if math.isinf(limit):  # 1 µs dust at 60 Hz is dt/tau = 16,667: still bounded
        assert min(r["tau"] for r in sweep if r["outcome"] == "bounded"
                   and r["integrator"] == integrator.value) == pytest.approx(1e-6)


def test_rk4_reaches_further_than_rk2(sweep):
    at = {(r["integrator"], r["dt"]): r for r in sweep if 2.3 < r["dt_over_tau"] < 2.5}
    for dt in STEPS:
        assert at[("rk4", dt)]["outcome"] == "bounded"
        assert at[("rk2", dt)]["outcome"] == "divergent"


def test_theory_reads_the_drag_laws_stiffness():
    """A drag law whose rate exceeds 1/tau (Schiller-Naumann at a slip) is held to its own
    h = dt lambda: the hook the slip-dependent laws plug into."""
    end = np.zeros(4, dtype=PARTICLE_DTYPE)  # four bounded particles of class 0
    tau = 1 / 60 / 1.5  # dt/tau = 1.5: Stokes drag is within explicit Euler's limit of 2
    stokes = outcome_row(DRAG_CASES[0], Integrator.EXPLICIT_EULER, 1 / 60, 0, tau, end, 4)
    assert (stokes["stiffness"], stokes["theory"]) == (pytest.approx(1.5), "bounded")
    faster = DragCase("twice", {}, lambda dt, tau: 2 * dt / tau)
    row = outcome_row(faster, Integrator.EXPLICIT_EULER, 1 / 60, 0, tau, end, 4)
    assert (row["drag"], row["stiffness"], row["theory"]) == ("twice", pytest.approx(3.0),
                                                               "divergent")
    assert not row["agrees"]  # a bounded outcome there would disagree with theory


EXPECTED = {
    "negative dt": "rejected", "NaN dt": "rejected", "infinite dt": "rejected",
    "NaN wand": "rejected", "infinite wand": "rejected", "huge wand (1e30 m)": "clamped",
    "dt spike of 1 s (master, real time)": "clamped",
    "dt spike of 1 s (engine, explicit_euler)": "stable",
    "dt spike of 1 s (engine, exponential)": "stable",
    "dt spike of 1 s (engine, etd2rk)": "stable",
    "dt = 0": "stable", "field of 1e6 m/s": "stable",
    "particles 1e6 m outside the domain": "stable",
    "emission of 1e9/s beyond capacity": "stable", "zero capacity": "stable",
    "empty scene": "stable",
}


def test_each_extreme_case_has_its_outcome_and_stays_finite(gl_session):
    rows = {r["case"]: r for r in run_extremes(gl_session)}
    assert {case: r["outcome"] for case, r in rows.items()} == EXPECTED
    assert all(r["state_finite"] for r in rows.values())
    spike = rows["dt spike of 1 s (master, real time)"]
    assert spike["max_dt_sent"] == pytest.approx(1 / 60) and spike["frames_in_burst"] == 4
    assert rows["dt = 0"]["unchanged"]
    assert rows["emission of 1e9/s beyond capacity"]["live"] == 1000
    assert rows["particles 1e6 m outside the domain"]["live"] == 100
