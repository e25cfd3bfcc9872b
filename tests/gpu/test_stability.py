"""Stiff and extreme cases: the outcomes match theory, and no NaN ever reaches the state."""

import math

import numpy as np
import pytest

from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.tools.stability.extremes import run_extremes
from cavesim.tools.stability.sweep import (
    BRACKET,
    DRAG_CASES,
    EXPLICIT_LIMITS,
    SCHILLER_NAUMANN,
    STEPS,
    STOKES,
    TAUS,
    DragCase,
    outcome_row,
    run_sweep,
    sweep_scene,
)

pytestmark = pytest.mark.xdist_group("stability")  # one sweep, on one worker


@pytest.fixture(scope="module")
def sweep(gl_session):
    return run_sweep(gl_session)


def test_every_stiff_outcome_matches_theory(sweep):
    assert len(sweep) == len(DRAG_CASES) * len(Integrator) * len(STEPS) * len(TAUS)
    for drag in DRAG_CASES:
        assert sum(r["drag"] == drag.name for r in sweep) == len(Integrator) * 2 * 25
    disagreements = [r for r in sweep if not r["agrees"]]
    assert not disagreements, disagreements[:3]
    assert all(r["state_finite"] for r in sweep), "no NaN or Inf in the GPU state"


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_each_integrator_is_bounded_exactly_below_its_limit(sweep, integrator):
    limit = integrator.stability_limit
    for row in (r for r in sweep if r["integrator"] == integrator.value):
        if row["drag"] == STOKES.name:  # one stiffness: the limit is sharp
            assert row["stiffness"] == row["stiffness_max"]
            assert (row["outcome"] == "bounded") == (row["stiffness"] < limit), row
        elif row["stiffness_max"] < limit:  # Schiller-Naumann: stable at every slip met
            assert row["outcome"] == "bounded", row
        elif row["stiffness"] > limit:  # not even the settled slip is stable
            assert row["outcome"] == "divergent", row
    if math.isinf(limit):  # 1 µs dust at 60 Hz is dt/tau = 16,667: still bounded
        assert min(r["tau"] for r in sweep if r["outcome"] == "bounded"
                   and r["integrator"] == integrator.value) == pytest.approx(1e-6)


def test_schiller_naumann_is_stiffer_than_stokes_with_the_slip(sweep):
    """The Jacobian along the slip is (1 + 0.253 Re^0.687)/tau: the settled stiffness of
    1 mm sand (tau = 10 s, settling Re ~ 390) is ~20x Stokes', and fine dust's Re ~ 0
    leaves it at Stokes'."""
    rows = {(r["drag"], r["integrator"], r["dt"], r["tau"]): r for r in sweep}
    sand = rows[("schiller_naumann", "rk4", 1 / 60, TAUS[0])]
    assert sand["stiffness"] / sand["dt_over_tau"] > 15
    dust = rows[("schiller_naumann", "rk4", 1 / 60, TAUS[-1])]
    assert dust["stiffness"] == pytest.approx(dust["dt_over_tau"], rel=1e-3)
    assert all(r["stiffness_max"] >= r["stiffness"] >= r["dt_over_tau"] * (1 - 1e-12)
               for r in sweep)


def test_schiller_naumann_on_the_gpu_diverges_at_a_slip_stokes_survives(gl_session):
    """Explicit Euler at dt/tau = 1.2: Stokes drag relaxes a 40 m/s slip (|1 - 1.2| < 1);
    Schiller-Naumann's rate at that slip is ~7.5x larger (Re ~ 110), so the step
    overshoots and grows: the GPU applies the drag of each particle's own slip."""
    tau = 1 / 30 / 2.4
    class_id = TAUS.index(tau)
    speeds = {}
    for drag in (STOKES, SCHILLER_NAUMANN):
        system = ParticleSystem(gl_session, sweep_scene(Integrator.EXPLICIT_EULER, 4, drag))
        start = np.zeros(4, dtype=PARTICLE_DTYPE)
        start["vel"] = [[40.0, 0.0, 0.0], [0.0, 40.0, 0.0], [0.0, 0.0, 40.0], [-40.0, 0, 0]]
        start["lifetime"] = 1e6
        start["class_id"] = class_id
        system.write_particles(start)
        for _ in range(30):
            system.step(FrameInput(1 / 60, np.eye(3, dtype=np.float32)))
        end = system.read_particles()
        speeds[drag.name] = (len(end), float(np.abs(end["vel"]).max(initial=0.0)))
        system.release()
    assert speeds["stokes"][0] == 4 and speeds["stokes"][1] < 5.0, speeds
    assert speeds["schiller_naumann"][0] < 4 or speeds["schiller_naumann"][1] > 1e3, speeds


@pytest.mark.parametrize("limit", EXPLICIT_LIMITS)
@pytest.mark.parametrize("dt", STEPS)
def test_each_explicit_limit_is_bracketed_within_five_percent_at_every_dt(sweep, dt, limit):
    """At h = 0.95 and 1.05 times a limit, every method with that limit is bounded and
    divergent as theory says (Stokes drag: one stiffness)."""
    methods = [i.value for i in Integrator if i.stability_limit == limit]
    rows = [r for r in sweep if r["drag"] == STOKES.name and r["dt"] == dt
            and r["integrator"] in methods]
    for side, outcome in ((-1, "bounded"), (1, "divergent")):
        h = limit * (1 + side * BRACKET)
        at = [r for r in rows if r["stiffness"] == pytest.approx(h)]
        assert len(at) == len(methods)
        assert all(r["outcome"] == r["theory"] == outcome for r in at), at


def test_rk4_reaches_further_than_rk2(sweep):
    at = {(r["integrator"], r["dt"]): r for r in sweep
          if r["drag"] == STOKES.name and 2.3 < r["dt_over_tau"] < 2.5}
    for dt in STEPS:
        assert at[("rk4", dt)]["outcome"] == "bounded"
        assert at[("rk2", dt)]["outcome"] == "divergent"


def test_theory_reads_the_drag_laws_stiffness():
    """A drag law whose rate exceeds 1/tau (Schiller-Naumann at a slip) is held to its own
    h = dt lambda: the hook the slip-dependent laws plug into."""
    end = np.zeros(4, dtype=PARTICLE_DTYPE)  # four bounded particles of class 0
    tau = 1 / 60 / 1.5  # dt/tau = 1.5: Stokes drag is within explicit Euler's limit of 2
    stokes = outcome_row(STOKES, Integrator.EXPLICIT_EULER, 1 / 60, 0, tau, end, 4, 1.0)
    assert (stokes["stiffness"], stokes["theory"]) == (pytest.approx(1.5), "bounded")
    faster = DragCase("twice", jacobian_rate=lambda tau, slip: 2 / tau)
    row = outcome_row(faster, Integrator.EXPLICIT_EULER, 1 / 60, 0, tau, end, 4, 1.0)
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
    "emitter launching at 1e14 m/s": "rejected", "dust launched at 1e14 m/s": "dropped",
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
    assert rows["dust launched at 1e14 m/s"]["live"] == 0
    assert "speed" in rows["emitter launching at 1e14 m/s"]["user_sees"]
    for name in ("explicit_euler", "exponential", "etd2rk"):
        row = rows[f"dt spike of 1 s (engine, {name})"]
        said = "ran away and were dropped" in row["user_sees"]
        assert said == (row["ran_away"] > 0) and row["particles"] > 1000, row
