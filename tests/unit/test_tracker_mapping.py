"""From DTrack's room and bodies to the CAVE's (cavesim.core.tracking.mapping, .rotation):
millimetres to metres, axes swapped and turned, offsets; quaternions that the projection
and the helicopter read as the pose DTrack measured; the mapping file checked key by key."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from dtrack_packets import HEAD_MM, TRACKED

from cavesim.core.cave.projection import eye_positions
from cavesim.core.errors import TrackerError
from cavesim.core.helicopter.flight import heading_of, tilt_of
from cavesim.core.tracking import Body, Target, Tracked, TrackerMapping, parse_datagram
from cavesim.core.tracking.mapping import load_mapping, parse_mapping
from cavesim.core.tracking.rotation import (
    axes_matrix,
    is_frame,
    is_rotation,
    quaternion_of,
    yaw_matrix,
)

ROOT = Path(__file__).parents[2]
HEAD = Target(Tracked.BODY, 0)


def rx(degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def matrix_of(q) -> np.ndarray:
    """The rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def body(position=(0.0, 0.0, 0.0), rotation=None) -> Body:
    """A tracked body at `position` (mm), turned by `rotation` (default: none)."""
    m = np.eye(3) if rotation is None else rotation
    return Body(0, 1.0, tuple(position), tuple(map(tuple, m.tolist())))


# --- rotations --------------------------------------------------------------------------

def test_quaternions_rebuild_their_matrices_also_near_a_half_turn():
    rng = np.random.default_rng(7)
    turns = [np.eye(3), rx(180), yaw_matrix(180), np.diag([-1.0, 1.0, -1.0]),
             yaw_matrix(179.999) @ rx(0.001)]
    for _ in range(200):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        turns.append(q * np.sign(np.linalg.det(q)))
    for m in turns:
        q = quaternion_of(m)
        assert math.isclose(math.hypot(*q), 1.0) and q[3] >= 0
        np.testing.assert_allclose(matrix_of(q), m, atol=1e-12)


def test_named_axes_and_yaw():
    assert is_frame(("x", "y", "z")) and is_frame(("x", "-z", "y")) and is_frame(("-x", "-y", "z"))
    for bad in (("y", "x", "z"), ("x", "x", "z"), ("x", "y"), ("x", "y", "w"), ("x", "y", "+z"),
                ("-x", "y", "z")):
        assert not is_frame(bad), bad
    np.testing.assert_array_equal(axes_matrix(("x", "-z", "y")) @ [1, 2, 3], [1, -3, 2])
    np.testing.assert_allclose(yaw_matrix(90) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    assert is_rotation(yaw_matrix(33), 1e-12) and not is_rotation(np.diag([1, 1, -1.0]), 0.1)


# --- poses ------------------------------------------------------------------------------

def test_millimetres_become_metres_and_the_head_reads_as_measured():
    datagram = parse_datagram(TRACKED)
    position, q = TrackerMapping(HEAD).pose(HEAD, datagram.bodies[0])
    assert position == pytest.approx(tuple(x / 1000 for x in HEAD_MM))
    assert math.degrees(heading_of(q)) == pytest.approx(30.0, abs=1e-4)  # turned left
    eyes = eye_positions(position, q, ipd=0.064, stereo=True)
    right = (eyes["right"] - eyes["left"]) / 0.064
    np.testing.assert_allclose(right, np.array(datagram.bodies[0].rotation)[:, 0], atol=1e-6)


def test_a_flystick_pitched_up_tilts_the_wand():
    stick = parse_datagram(TRACKED).flysticks[0]
    wand = Target(Tracked.FLYSTICK, 0)
    _, q = TrackerMapping(wand=wand).pose(wand, stick)
    assert tilt_of(q) == pytest.approx(20.0, abs=1e-4) and heading_of(q) == pytest.approx(0.0)


def test_a_y_up_room_calibration_maps_onto_z_up():
    powerwall = ("x", "-z", "y")  # DTrack: y up, z toward the viewer
    head = Target(Tracked.BODY, 0, axes=powerwall)  # calibrated "due to room"
    mapping = TrackerMapping(head, axes=powerwall)
    position, q = mapping.pose(head, body((100.0, 1700.0, -500.0)))
    assert position == pytest.approx((0.1, 0.5, 1.7))
    assert q == pytest.approx((0.0, 0.0, 0.0, 1.0))  # looking at the front wall, level
    looking_up = body(rotation=rx(30))  # about DTrack's x: the head's right axis
    assert tilt_of(mapping.pose(head, looking_up)[1]) == pytest.approx(30.0)


def test_yaw_and_offsets():
    mapping = TrackerMapping(HEAD, yaw=90.0, offset=(0.5, 0.0, 0.1))
    position, q = mapping.pose(HEAD, body((1000.0, 0.0, 0.0)))
    assert position == pytest.approx((0.5, 1.0, 0.1))  # DTrack's x is the CAVE's y
    assert q == pytest.approx((0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)))
    eyes = Target(Tracked.BODY, 0, offset=(0.0, 0.1, -0.03))  # 10 cm ahead, 3 cm below
    position, _ = TrackerMapping(eyes).pose(eyes, body((0.0, 0.0, 1700.0), yaw_matrix(90)))
    assert position == pytest.approx((-0.1, 0.0, 1.67))  # ahead is -x after a left turn


# --- the file ---------------------------------------------------------------------------

def test_the_example_mapping_loads():
    mapping = load_mapping(ROOT / "config" / "tracking" / "dtrack.toml")
    assert mapping.head == Target(Tracked.BODY, 0) and mapping.wand == Target(Tracked.FLYSTICK, 0)


def test_a_full_mapping_and_one_target_alone():
    data = {"room": {"axes": ["x", "-z", "y"], "yaw": -12.5, "offset": [1, 2, 0]},
            "head": {"body": 2, "axes": ["-x", "-y", "z"], "offset": [0, 0, -0.03]},
            "wand": {"body": 5}}
    assert parse_mapping(data) == TrackerMapping(
        Target(Tracked.BODY, 2, ("-x", "-y", "z"), (0.0, 0.0, -0.03)), Target(Tracked.BODY, 5),
        ("x", "-z", "y"), -12.5, (1.0, 2.0, 0.0))
    assert parse_mapping({"wand": {"flystick": 1}}).head is None


@pytest.mark.parametrize(("data", "message"), [
    ({"head": {"body": 0}, "room": {"axes": ["y", "x", "z"]}},
     "room.axes = ['y', 'x', 'z'] is not allowed: must be a list of 3 non-empty strings, x, y "
     "and z once each, '-' for a reversed axis, turning and not mirroring"),
    ({"head": {"body": 0, "axes": ["x", "up", "z"]}}, "head.axes = ['x', 'up', 'z'] is not"),
    ({"head": {"body": 0}, "room": {"yaw": 400}},
     "room.yaw = 400 is not allowed: must be a finite number >= -360 and <= 360"),
    ({"head": {"body": 0}, "room": {"offset": [0, 0]}},
     "room.offset = [0, 0] is not allowed: must be a list of 3 finite numbers"),
    ({"head": {"body": -1}}, "head.body = -1 is not allowed: must be an integer >= 0, DTrack's"),
    ({"head": {"body": 0, "flystick": 0}},
     "head.flystick = 0 is not allowed: head.body is given too; a head follows one body"),
    ({"wand": {"axes": ["x", "y", "z"]}},
     "wand.body is missing: required, body = ID (a 6d body) or flystick = ID"),
    ({"room": {}}, "head and wand are missing: a mapping needs a [head] table, a [wand] table"),
    ({"head": 0}, "head = 0 is not allowed: must be a table, written [head]"),
    ({"head": {"body": 0}, "hand": {}}, "hand = {} is not allowed: unknown key; allowed keys "
                                        "here: room, head, wand"),
])
def test_a_bad_mapping_names_the_key_the_value_and_what_is_allowed(data, message):
    with pytest.raises(TrackerError, match=f"^<dict>: {re.escape(message)}"):
        parse_mapping(data)


def test_an_unreadable_mapping_file_is_named(tmp_path):
    with pytest.raises(TrackerError, match="cannot read tracker mapping"):
        load_mapping(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[head\n")
    with pytest.raises(TrackerError, match=f"^{re.escape(str(bad))}: not valid TOML"):
        load_mapping(bad)
