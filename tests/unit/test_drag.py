"""Drag beyond Stokes: the Schiller-Naumann law against the issue's figures, the loader's
choice of law per class, and the float64 twin's drag (settling, the frozen exponential
step)."""

import dataclasses
import math

import numpy as np
import pytest

from cavesim.core.drag import STOKES_REYNOLDS_LIMIT, drag_factor, terminal_speed
from cavesim.core.features.schiller_naumann import chosen_law, flow_scales
from cavesim.core.features.stokes_drag import Drag
from cavesim.core.fields.snapshot_time import END
from cavesim.core.scene import (
    AIR_VISCOSITY,
    DragLaw,
    Integrator,
    ParticleClass,
    load_scene,
    parse_scene,
)
from cavesim.core.twin.integrators import INTEGRATORS, exponential_weights
from cavesim.core.twin.system import TwinSystem

SAND = ParticleClass("sand", 150e-6, 2650.0)
AIR = Drag()
NU, MU, G = AIR.kinematic_viscosity, AIR.air_viscosity, 9.81


def test_air_is_dry_air_at_15_celsius():
    assert AIR.air_viscosity == AIR_VISCOSITY == 1.81e-5
    assert NU == pytest.approx(1.478e-5, rel=1e-3)


def test_sand_settles_at_the_reviewed_speeds():
    """150 um sand: 1.80 m/s under Stokes, 1.03 m/s under Schiller-Naumann (reviewed)."""
    stokes = terminal_speed(SAND, False, NU, MU, G)
    schiller = terminal_speed(SAND, True, NU, MU, G)
    assert stokes == pytest.approx(1.80, abs=0.005)
    assert schiller == pytest.approx(1.03, abs=0.005)
    reynolds = schiller * SAND.diameter / NU
    assert drag_factor(reynolds) * schiller == pytest.approx(stokes, rel=1e-9)
    assert 10 < reynolds < 11


def test_drag_at_10_m_s_slip():
    """Re = 101.5 at 10 m/s slip: Schiller-Naumann drags 4.59 times as hard as Stokes.
    (The issue's "about 3.8x" is the factor at 7 m/s, Re = 71.)"""
    assert 10.0 * SAND.diameter / NU == pytest.approx(101.5, abs=0.1)
    assert drag_factor(10.0 * SAND.diameter / NU) == pytest.approx(4.59, abs=0.01)
    assert drag_factor(7.0 * SAND.diameter / NU) == pytest.approx(3.8, abs=0.05)
    assert drag_factor(STOKES_REYNOLDS_LIMIT) == pytest.approx(1.05, abs=0.002)


def still_air_scene(integrator: Integrator, drag: str | None = None):
    sand = {"name": "sand", "diameter": 150e-6, "density": 2650.0}
    if drag is not None:
        sand["drag"] = drag
    return parse_scene({
        "simulation": {"capacity": 8, "seed": 1, "integrator": integrator.value,
                       "random_texture_size": 16},
        "particle_class": [sand],
        "forces": {"gravity": [0.0, 0.0, -9.81], "drag": {}},
        "field": {"kind": "uniform", "box_min": [-1e3] * 3, "box_max": [1e3] * 3,
                  "resolution": [2, 2, 2], "params": {"velocity": [0.0, 0.0, 0.0]}},
    }, name="still")


@pytest.mark.parametrize("integrator", [Integrator.ETD2RK, Integrator.EXPONENTIAL,
                                        Integrator.RK4, Integrator.SEMI_IMPLICIT_EULER])
@pytest.mark.parametrize(("drag", "speed"), [(None, 1.03), ("stokes", 1.80)])
def test_the_twin_settles_sand_at_its_terminal_speed(integrator, drag, speed):
    """Dropped from rest in still air, after 2 s (about 10 relaxation times)."""
    scene = still_air_scene(integrator, drag)
    twin = TwinSystem(scene)
    forces = twin.forces_for(np.zeros(1, np.uint32))
    p, v = np.zeros((1, 3)), np.zeros((1, 3))
    step = INTEGRATORS[integrator]
    for _ in range(120):
        p, v = step(p, v, 1 / 60, forces)
    assert -v[0, 2] == pytest.approx(speed, abs=0.005)


def test_etd2rk_takes_the_drag_rate_of_the_predicted_state_in_its_second_stage():
    """In a flow that changes along the path, ETD2RK's second stage evaluates the remainder
    of the linear part at the predicted state (pa, va), with the drag rate of the slip
    there: N = u lambda_a + g - (lambda_a - lambda_0) v. Held at lambda_0 instead, the method
    is first order (tests/gpu/test_accuracy.py holds the order)."""
    twin = TwinSystem(still_air_scene(Integrator.ETD2RK))
    base = twin.forces_for(np.zeros(1, np.uint32))
    forces = dataclasses.replace(base, flow=lambda p, stage: np.stack(
        [3.0 * p[:, 2], np.zeros(len(p)), np.zeros(len(p))], axis=1))
    p, v, h = np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 5.0]]), 1 / 60
    f, lam, drag = forces.linear_parts(p, v)
    assert drag[0, 0] == pytest.approx(drag_factor(np.hypot(3.0, 5.0) * SAND.diameter / NU)
                                       / SAND.relaxation_time(MU))
    _, phi1, phi2 = exponential_weights(lam * h)
    pa = p + h * (v + h * phi2 * (f - lam * v))
    va = v + h * phi1 * (f - lam * v)
    slip = forces.flow(pa, END) - va
    drag_a = drag_factor(np.linalg.norm(slip) * SAND.diameter / NU) / SAND.relaxation_time(MU)
    assert abs(drag_a / drag[0, 0] - 1) > 0.01, "the rate changes over the step"
    d = forces.flow(pa, END) * drag_a + forces.gravity - (drag_a - drag) * va - f
    expected = v + h * (phi1 * (f - lam * v) + phi2 * d)
    _, v1 = INTEGRATORS[Integrator.ETD2RK](p, v, h, forces)
    # the twin's constants are float32-rounded (as the GPU's): 1e-6, against a 5% change
    np.testing.assert_allclose(v1, expected, rtol=1e-6)


def test_the_exponential_step_freezes_the_drag_rate_at_the_start():
    """One step is exact for dv/dt = f - lambda v with lambda from the starting slip."""
    twin = TwinSystem(still_air_scene(Integrator.EXPONENTIAL))
    forces = twin.forces_for(np.zeros(1, np.uint32))
    v0 = np.array([[10.0, 0.0, 0.0]])
    h = 1 / 60
    _, v1 = INTEGRATORS[Integrator.EXPONENTIAL](np.zeros((1, 3)), v0, h, forces)
    tau = SAND.relaxation_time(MU)
    lam = drag_factor(10.0 * SAND.diameter / NU) / tau
    g = np.array([0.0, 0.0, -9.81])
    exact = g / lam + (v0 - g / lam) * math.exp(-lam * h)
    np.testing.assert_allclose(v1, exact, rtol=1e-6)
    a = forces.acceleration(np.zeros((1, 3)), v0)
    stokes = -10.0 / tau
    assert a[0, 0] / stokes == pytest.approx(4.59, abs=0.01)


@pytest.mark.parametrize(("diameter", "law"), [(150e-6, DragLaw.SCHILLER_NAUMANN),
                                               (10e-6, DragLaw.STOKES)])
def test_the_loader_gives_brownout_classes_their_law(diameter, law):
    scene = load_scene("config/scenes/brownout.toml")
    [particle] = [c for c in scene.particle_classes if c.diameter == diameter]
    assert particle.drag is law
    sn = law is DragLaw.SCHILLER_NAUMANN
    index = scene.particle_classes.index(particle)
    assert (scene.reynolds_per_speed()[index] > 0) == sn


def test_the_rule_counts_the_lag_behind_the_flow():
    """20 um grains settle at Re 0.05 but lag a 27 m/s rotor wash by Re ~ 0.4."""
    grain = ParticleClass("silt", 20e-6, 2650.0)
    still = (0.0, math.inf)
    assert chosen_law(grain, NU, MU, G, still) is DragLaw.STOKES
    helicopter = load_scene("config/scenes/brownout.toml")
    flow = flow_scales(helicopter.field, helicopter.helicopter)
    assert flow[0] == pytest.approx(27.0, abs=0.5) and flow[1] == 7.3
    assert chosen_law(grain, NU, MU, G, flow) is DragLaw.SCHILLER_NAUMANN
    assert chosen_law(SAND, NU, MU, G, still) is DragLaw.SCHILLER_NAUMANN


def test_a_named_law_is_kept():
    scene = still_air_scene(Integrator.RK4, "stokes")
    assert scene.particle_classes[0].drag is DragLaw.STOKES
    assert scene.reynolds_per_speed() == (0.0,)
