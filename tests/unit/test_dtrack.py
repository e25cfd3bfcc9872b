"""DTrack2's ASCII datagrams (cavesim.core.tracking.dtrack): recorded ones parse to the
poses, buttons and joystick they carry; malformed ones are refused with a reason to count,
and nothing else ever comes out of the parser."""

from __future__ import annotations

import math

import pytest
from dtrack_packets import (
    FLYSTICK_HIDDEN,
    FLYSTICK_MM,
    HEAD_LOST,
    HEAD_MM,
    NOTHING,
    THREE_DECIMALS,
    TRACKED,
    TWO_FLYSTICKS,
    datagram,
)
from hypothesis import given
from hypothesis import strategies as st

from cavesim.core.errors import ProtocolError
from cavesim.core.tracking.dtrack import (
    MAX_DATAGRAM,
    MAX_POSITION_MM,
    Datagram,
    parse_datagram,
)

IDENTITY = "[1 0 0 0 1 0 0 0 1]"
HEAD = "[0 1.000][1 2 3 0 0 0]" + IDENTITY
FLYSTICK = "[0 1.000 6 2][1 2 3]" + IDENTITY


def test_a_tracked_frame_gives_every_body_and_the_flystick():
    d = parse_datagram(TRACKED)
    assert (d.frame, d.timestamp) == (21753, 39596.024831)
    assert sorted(d.bodies) == [0, 3] and sorted(d.flysticks) == [0]
    head = d.bodies[0]
    assert head.tracked and head.quality == 1.0 and head.position == HEAD_MM
    # DTrack writes the matrix column by column: its first three numbers are column 0
    assert [row[0] for row in head.rotation] == [0.866025, 0.5, 0.0]
    assert head.rotation[0] == (0.866025, -0.492404, -0.086824)
    assert d.bodies[3].quality == 0.871
    stick = d.flysticks[0]
    assert stick.tracked and stick.position == FLYSTICK_MM
    assert (stick.buttons, stick.controllers) == (0b101, (0.25, -1.0))


def test_a_body_out_of_view_is_left_out():
    d = parse_datagram(HEAD_LOST)
    assert sorted(d.bodies) == [3] and d.flysticks[0].buttons == 1


def test_a_hidden_flystick_has_no_pose_but_its_buttons_and_joystick():
    stick = parse_datagram(FLYSTICK_HIDDEN).flysticks[0]
    assert not stick.tracked and stick.quality == -1.0
    assert (stick.buttons, stick.controllers) == (16, (-0.5, 0.0))  # zeros are no rotation


def test_older_output_with_three_decimals_and_empty_lines():
    assert parse_datagram(THREE_DECIMALS).bodies[0].position == (326.848, -187.216, 109.482)
    d = parse_datagram(NOTHING)
    assert d == Datagram(21760, 39596.141498, {}, {})


def test_many_buttons_keep_the_first_32_and_flysticks_their_own_controllers():
    sticks = parse_datagram(TWO_FLYSTICKS).flysticks
    assert sticks[1].buttons == 2**31 + 1 and sticks[1].controllers == (1.0,)
    assert sticks[0].buttons == 0 and sticks[1].quality == 0.95
    assert parse_datagram(TWO_FLYSTICKS).timestamp is None


def test_line_ends_a_trailing_nul_and_other_line_types_are_accepted():
    lf = TRACKED.replace(b"\r\n", b"\n") + b"\0"
    assert parse_datagram(lf) == parse_datagram(TRACKED)
    extra = datagram("fr 5", "3d 1 [7 1.000][1.0 2.0 3.0]", "gl 0", "6dmt 0 0", "6d 1 " + HEAD)
    assert parse_datagram(extra).bodies[0].position == (1.0, 2.0, 3.0)
    assert parse_datagram(datagram("6d 1 " + HEAD)).frame is None


MALFORMED = [
    (b"", "no-data"),
    (b"hello world\r\n", "no-data"),
    (b"fr 1\r\n\xff\xfe", "not-ascii"),
    (b"fr 1\r\n" + b" " * MAX_DATAGRAM, "too-large"),
    (datagram("Fr 1"), "bad-line"),
    (datagram("fr 1", "fr 2"), "bad-line"),
    (datagram("fr -1"), "bad-number"),
    (datagram("fr 1.5"), "bad-number"),
    (datagram("ts -3.0"), "bad-value"),
    (datagram("ts 1 2"), "bad-value"),
    (datagram("6d 2 " + HEAD), "bad-count"),
    (datagram("6d " + HEAD), "bad-count"),
    (datagram("6d 1 [0 1.000][1 2 3]" + IDENTITY), "bad-count"),
    (datagram("6d 1 [0][1 2 3 0 0 0]" + IDENTITY), "bad-count"),
    (datagram("6d 1 [0 1.000][1 2 3 0 0 0]" + IDENTITY + " junk"), "bad-line"),
    (datagram("6d 1 [0 1.000[1 2 3 0 0 0]" + IDENTITY), "bad-line"),
    (datagram("6d 1 [0 1.000][nan 2 3 0 0 0]" + IDENTITY), "bad-number"),
    (datagram("6d 1 [0 1.000][inf 2 3 0 0 0]" + IDENTITY), "bad-number"),
    (datagram("6d 1 [0 1.000][1e999 2 3 0 0 0]" + IDENTITY), "non-finite"),
    (datagram(f"6d 1 [0 1.000][{2 * MAX_POSITION_MM} 2 3 0 0 0]" + IDENTITY), "bad-value"),
    (datagram("6d 1 [0 1.5][1 2 3 0 0 0]" + IDENTITY), "bad-value"),
    (datagram("6d 1 [0 1.000][1 2 3 0 0 0][2 0 0 0 2 0 0 0 2]"), "bad-rotation"),
    (datagram("6d 1 [0 1.000][1 2 3 0 0 0][0 1 0 1 0 0 0 0 1]"), "bad-rotation"),  # a mirror
    (datagram("6d 1 [0 1.000][1 2 3 0 0 0][0 0 0 0 0 0 0 0 0]"), "bad-rotation"),
    (datagram("6d 2 " + HEAD + " " + HEAD), "bad-value"),  # id 0 twice
    (datagram("6df2 1 2 " + FLYSTICK + "[0 0 0] [1 1.000 6 2][1 2 3]" + IDENTITY + "[0 0 0]"),
     "bad-count"),  # two reported, one defined
    (datagram("6df2 1 1 " + FLYSTICK + "[0 0]"), "bad-count"),
    (datagram("6df2 1 1 [0 1.000 6][1 2 3]" + IDENTITY + "[0 0 0]"), "bad-count"),
    (datagram("6df2 1 1 " + FLYSTICK + "[64 0 0]"), "bad-value"),  # button 6 of 6
    (datagram("6df2 1 1 " + FLYSTICK + "[4294967296 0 0]"), "bad-value"),
    (datagram("6df2 1 1 " + FLYSTICK + "[-1 0 0]"), "bad-number"),
    (datagram("6df2 1 1 " + FLYSTICK + "[1 1.5 0]"), "bad-value"),
    (datagram("6df2 1 1 " + FLYSTICK + "[1 0 nan]"), "bad-number"),
]


@pytest.mark.parametrize(("data", "reason"), MALFORMED)
def test_a_malformed_datagram_is_refused_with_a_reason(data: bytes, reason: str):
    with pytest.raises(ProtocolError) as info:
        parse_datagram(data)
    assert info.value.reason == reason
    assert len(str(info.value)) < 300 and "\n" not in str(info.value)


def _assert_sane(d: Datagram) -> None:
    for body in (*d.bodies.values(), *d.flysticks.values()):
        values = (*body.position, *(x for row in body.rotation for x in row))
        assert all(math.isfinite(x) for x in values)
        assert all(abs(x) <= MAX_POSITION_MM for x in body.position)
    for stick in d.flysticks.values():
        assert 0 <= stick.buttons < 2**32 and all(abs(c) <= 1 for c in stick.controllers)


@given(st.binary(max_size=2000))
def test_random_bytes_are_refused_or_sane(data: bytes):
    try:
        _assert_sane(parse_datagram(data))
    except ProtocolError:
        pass


@given(st.integers(0, len(TRACKED)), st.integers(0, 40),
       st.text(alphabet="0123456789.-+e []nai\r\n", max_size=12))
def test_mutated_recordings_are_refused_or_sane(at: int, cut: int, insert: str):
    data = TRACKED[:at] + insert.encode() + TRACKED[at + cut:]
    try:
        _assert_sane(parse_datagram(data))
    except ProtocolError:
        pass
