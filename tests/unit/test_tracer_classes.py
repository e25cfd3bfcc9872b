"""Passive tracer classes: how a scene declares them, what the loader refuses in one line,
and the float64 twin's tracer methods at their table's orders in a solid-body vortex."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scenes import SMOKE, scene_dict

from cavesim.core.errors import SceneError
from cavesim.core.scene import Motion, TracerMethod, parse_scene
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.tracers import TRACERS
from cavesim.tools.numerics.solid_body import disk, rotated, solid_body

FINAL_TIME = 1.0  # s
ORDER_DTS = (1 / 30, 1 / 60, 1 / 120, 1 / 240)


def with_smoke(**kwargs) -> dict:
    data = copy.deepcopy(scene_dict(**kwargs))
    data["particle_class"].append(dict(SMOKE))
    return data


def test_a_tracer_class_mixes_with_inertial_ones_and_has_no_drag():
    scene = parse_scene(with_smoke(integrator="rk4"), name="mixed")
    smoke = scene.particle_classes[2]
    assert smoke.motion is Motion.TRACER and smoke.density is None and smoke.drag is None
    assert scene.tracer_classes == (False, False, True)
    assert scene.inverse_relaxation_times()[2] == 0.0 and scene.reynolds_per_speed()[2] == 0.0
    assert all(t > 0 for t in scene.inverse_relaxation_times()[:2])
    assert scene.particle_classes[0].motion is Motion.INERTIAL  # the default


def refuse(data: dict, *needles: str) -> None:
    with pytest.raises(SceneError) as caught:
        parse_scene(data, name="bad")
    message = str(caught.value)
    assert "\n" not in message
    for needle in needles:
        assert needle in message, f"{needle!r} not in {message!r}"


@pytest.mark.parametrize("key", ["density", "drag"])
def test_a_tracer_refuses_what_only_inertia_needs(key):
    data = with_smoke()
    data["particle_class"][2][key] = 1000.0 if key == "density" else "stokes"
    refuse(data, f"particle_class[2].{key}", "only for an inertial class",
           "a tracer class allows name, diameter and motion")


def test_an_inertial_class_still_needs_its_density():
    data = with_smoke()
    del data["particle_class"][0]["density"]
    refuse(data, "particle_class[0].density is missing", 'or motion = "tracer"')


def test_a_tracer_needs_the_flow_and_refuses_dispersion():
    data = with_smoke(drag=False)
    refuse(data, "particle_class[2].motion = 'tracer'", "needs forces.drag")
    data = with_smoke(collision={"kind": "plane", "height": 0.0, "friction": 0.2,
                                 "resilience": 0.5},
                      dispersion={"mixing_length": 1.0})
    refuse(data, "particle_class[2].motion = 'tracer'", "not allowed with forces.dispersion",
           'allowed: "inertial"')
    data["particle_class"][2]["motion"] = "ghost"
    refuse(data, "particle_class[2].motion = 'ghost'", "'inertial', 'tracer'")


# -- the float64 twin's tracer steps against a rotation in closed form -------------------


def rms_error(method: TracerMethod, dt: float) -> float:
    forces = ForceModel(gravity=None, damping=None, inv_tau=None, flow=solid_body)
    start = disk(200)
    p = start
    for _ in range(round(FINAL_TIME / dt)):
        p, v = TRACERS[method](p, dt, forces)
    np.testing.assert_array_equal(v, solid_body(p))  # the record's velocity: the flow there
    return float(np.sqrt(np.mean(np.sum((p - rotated(start, FINAL_TIME)) ** 2, axis=1))))


@pytest.mark.parametrize("method", list(TracerMethod), ids=lambda m: m.value)
def test_each_tracer_method_has_its_order_in_the_analytic_vortex(method):
    # a fifth-order step meets float64's rounding by 1/240 s: its steps are twice as long
    dts = ORDER_DTS if method.order < 5 else tuple(2 * dt for dt in ORDER_DTS)
    errors = [rms_error(method, dt) for dt in dts]
    order = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert order == pytest.approx(method.order, abs=0.1), errors


@pytest.mark.parametrize("method", list(TracerMethod), ids=lambda m: m.value)
def test_each_tracer_step_samples_the_flow_as_its_row_says(method):
    """The row's evaluations, and one more at the new position: the record's velocity."""
    calls = []

    def counted(p, stage):
        calls.append(stage)
        return solid_body(p)

    TRACERS[method](disk(3), 0.1, ForceModel(None, None, None, counted))
    assert len(calls) == method.field_evaluations + 1
