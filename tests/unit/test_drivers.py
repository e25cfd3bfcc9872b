"""Scene drivers: the master's typed frame, its parameters on the wire, and back on a node."""

import numpy as np
import pytest

from cavesim.core.drivers import driver_for
from cavesim.core.drivers.helicopter import HelicopterDriver
from cavesim.core.drivers.still import StillDriver
from cavesim.core.errors import ProtocolError
from cavesim.core.helicopter.flight import WAND_LIMIT, pitch_quaternion
from cavesim.core.scene import load_scene
from cavesim.core.scene_frame import (
    MESH_HUB_HEIGHT,
    MESH_ROTOR_RADIUS,
    NOTHING_MOVES,
    TAIL_ROTOR_GEARING,
    HelicopterPose,
)
from cavesim.core.wire.payloads.poses import WandState

BROWNOUT = load_scene("config/scenes/brownout.toml")
MINIMAL = load_scene("config/scenes/minimal.toml")
FOLLOWERS = sum(e.follow_helicopter for e in BROWNOUT.emitters)


def test_each_scene_kind_gets_its_driver():
    assert isinstance(driver_for(BROWNOUT), HelicopterDriver)
    assert isinstance(driver_for(MINIMAL), StillDriver)


def test_helicopter_parameters_keep_their_layout_and_come_back_as_float32():
    driver = HelicopterDriver(BROWNOUT)
    step = driver.advance(1 / 60, 1 / 60, None)
    params = driver.encode(step.frame)
    rotor, pose = step.frame.rotor, step.frame.helicopter
    expected = (*rotor.hub, pose.yaw, pose.rotor_angle, rotor.induced_velocity,
                rotor.rotor_speed, *rotor.emission_factors)
    assert params == tuple(np.float32(expected).tolist())  # the frame log's layout
    assert len(params) == 7 + FOLLOWERS
    back = driver.decode(params)
    assert back.rotor.hub == params[:3] and back.rotor.emission_factors == params[7:]
    assert driver.encode(back) == params


@pytest.mark.parametrize("count", [0, 6, 7 + FOLLOWERS + 1])
def test_helicopter_parameters_of_another_length_are_a_protocol_error(count):
    with pytest.raises(ProtocolError, match=f"bad-params: a helicopter frame has "
                                            f"{7 + FOLLOWERS} parameters"):
        HelicopterDriver(BROWNOUT).decode((0.0,) * count)


def test_the_drawn_helicopter_stands_on_its_skids_with_its_rotor_at_the_hub():
    driver = HelicopterDriver(BROWNOUT)
    frame = driver.decode(driver.encode(driver.advance(1 / 60, 1 / 60, None).frame))
    hub = np.array(frame.rotor.hub)
    pose = frame.helicopter
    assert pose.position[2] == pytest.approx(hub[2] - BROWNOUT.helicopter.hub_height)
    np.testing.assert_allclose((pose.rotor_model() @ [0, 0, 0, 1])[:3], hub, atol=1e-5)
    np.testing.assert_allclose((pose.model() @ [0, 0, MESH_HUB_HEIGHT, 1])[:3], hub, atol=1e-5)
    rim = pose.rotor_model() @ [5.0, 0, 0, 1]  # the mesh's rotor radius, scaled
    assert np.linalg.norm(rim[:2] - hub[:2]) == pytest.approx(BROWNOUT.helicopter.rotor_radius)


def test_the_tail_rotor_turns_about_the_models_y_at_its_hub_geared_to_the_main_rotor():
    pose = HelicopterPose((1.0, 2.0, 0.5), 0.7, 0.3, hub_height=2 * MESH_HUB_HEIGHT)
    hub, radius = (-3.9, 0.08, 1.27), 0.32  # in the model frame
    disc = np.linalg.inv(pose.model()) @ pose.tail_rotor_model(hub, radius)  # model from disc
    np.testing.assert_allclose(disc[:3, 3], hub, atol=1e-12)
    turned = TAIL_ROTOR_GEARING * pose.rotor_angle
    blade = (np.cos(turned), 0.0, -np.sin(turned))  # the disc's x: blade 0, in the xz plane
    np.testing.assert_allclose(disc[:3, :3] * MESH_ROTOR_RADIUS / radius,
                               np.column_stack([blade, np.cross((0, 1, 0), blade), (0, 1, 0)]),
                               atol=1e-12)


def test_a_tracked_wand_out_of_reach_is_clamped_and_counted():
    far = WandState((1e30, 0.0, 1.0), pitch_quaternion(0.0))
    step = HelicopterDriver(BROWNOUT).advance(1 / 60, 1 / 60, far)
    assert step.clamped and step.wand == far  # the frame carries what was tracked
    near = HelicopterDriver(BROWNOUT).advance(1 / 60, 1 / 60,
                                             WandState((WAND_LIMIT, 0.0, 1.0)))
    assert not near.clamped


def test_the_flight_sample_is_the_skids_altitude_and_the_emission_rate():
    driver = HelicopterDriver(BROWNOUT)
    step = driver.advance(1 / 60, 1 / 60, None)
    rotor = step.frame.rotor
    assert step.flight.altitude == pytest.approx(rotor.hub[2] - BROWNOUT.helicopter.hub_height)
    rates = [e.rate for e in BROWNOUT.emitters if e.follow_helicopter]
    assert step.flight.emission_rate == pytest.approx(
        sum(r * f for r, f in zip(rates, rotor.emission_factors, strict=True)))


def test_a_still_scene_sends_nothing_and_draws_no_helicopter():
    driver = StillDriver()
    for t in (0.0, 0.1):
        step = driver.advance(t, 1 / 60, None)
        assert step.frame == NOTHING_MOVES and step.frame.helicopter is None
        assert step.wand == WandState() and driver.encode(step.frame) == ()
    assert driver.decode(()) == NOTHING_MOVES
    with pytest.raises(ProtocolError, match="bad-params: a still scene's frame has no "):
        driver.decode((1.0, 2.0, 3.0, 4.0, 5.0))
