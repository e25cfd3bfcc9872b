"""The frame log's records on their own (no GL): version 4 round trips and its bytes are
pinned, a version 3 log of every wire version it held still reads, other versions are
refused with one line, and the wire's version or frame layout moving changes no log byte.

Logs are crafted here from the documented layouts (cavesim/core/framelog/version4.py and
_version3.py), with the CRC framing done by hand, so these tests pin the formats rather
than echo the writer. The framing's torn and corrupt tails are tested on real version 4
logs in tests/processes/test_framelog.py.
"""

from __future__ import annotations

import hashlib
import json
import re
import struct
from dataclasses import replace
from pathlib import Path
from zlib import crc32

import numpy as np
import pytest
from cluster_helpers import digests, frame_messages
from hypothesis import given
from hypothesis import strategies as st

from cavesim.core.framelog import (
    TORN,
    VERSION,
    Damage,
    FrameLogError,
    FrameLogWriter,
    LoggedFrame,
    read_frame_log,
)
from cavesim.core.framelog.version4 import read_record, write_record
from cavesim.core.wire import FrameMessage, HeadState, WandState, encode, envelope
from cavesim.core.wire.payloads import from_master
from cavesim.gpu.engine import FrameInput

SESSION = "run"
FIELDS = struct.Struct("<I9f3f4f3f4fI4fH")  # dt bits, matrix, head, wand, buttons, axes, n
ENVELOPE = struct.Struct("<4sBBBBQQQI")  # the 36-byte header of a version 3 record
WIRE_VERSIONS = range(4, 13)  # those a version 3 log holds; 11 on with the events byte
EVENTS_SINCE = 11
MATRIX = np.array([[3, -2, 17], [5, 1, 250], [0, 0, 1]], dtype=np.float32)
FULL = FrameMessage(  # every field away from its default, float32-exact
    7, FrameInput(np.float32(1 / 60), MATRIX),
    WandState((0.5, -1.25, 2.0), (0.0, 0.5, 0.0, 0.875), 0b1011, (0.25, -0.5, 1.0, 0.0)),
    (24.0, -3.5, 0.0, 1e-3), HeadState((0.125, 0.25, 1.75), (0.0, 0.0, 0.5, 0.75)), True)
DIGEST = "00112233445566778899aabbccddeeff"


def comparable(logged: LoggedFrame) -> tuple:
    """A logged frame's fields, floats as float32 bits (so -0.0 != 0.0)."""
    m, w, h = logged.message, logged.message.wand, logged.message.head
    f32 = np.float32
    return (m.frame, f32(m.inputs.dt).tobytes(), m.inputs.random_transform.tobytes(),
            np.array([*w.position, *w.orientation, *w.axes, *h.position, *h.orientation,
                      *m.params], f32).tobytes(), w.buttons, len(m.params), m.reset,
            logged.digest, logged.particles)


def fields(m: FrameMessage, events: bool = True) -> bytes:
    """A frame's fields as the documented layout spells them, with or without events."""
    w, h = m.wand, m.head
    return FIELDS.pack(int(np.float32(m.inputs.dt).view(np.uint32)),
                       *m.inputs.random_transform.ravel().tolist(), *h.position,
                       *h.orientation, *w.position, *w.orientation, w.buttons, *w.axes,
                       len(m.params)) + struct.pack(f"<{len(m.params)}f", *m.params) + \
        (bytes([m.reset]) if events else b"")


def v4_payload(m: FrameMessage, digest: str = DIGEST, particles: int = 1234) -> bytes:
    return struct.pack("<Q", m.frame) + fields(m) + bytes.fromhex(digest) + \
        struct.pack("<I", particles)


def v3_payload(m: FrameMessage, wire: int, digest: str = DIGEST, particles: int = 1234,
               session: str = SESSION, kind: int = 1, flags: int = 0) -> bytes:
    """What the version 3 writer appended: the frame's unsigned envelope of wire version
    `wire` (run id 0), then the digest and live count."""
    body = fields(m, events=wire >= EVENTS_SINCE)
    sid = int.from_bytes(hashlib.blake2b(session.encode(), digest_size=8).digest(), "little")
    return ENVELOPE.pack(b"CVSM", wire, kind, flags, 0, sid, 0, m.frame, len(body)) + body + \
        bytes.fromhex(digest) + struct.pack("<I", particles)


def as_wire(payload: bytes, wire: int) -> bytes:
    """A version 3 payload whose envelope names wire version `wire` instead."""
    return payload[:4] + bytes([wire]) + payload[5:]


def framed(payload: bytes) -> bytes:
    size = struct.pack("<I", len(payload))
    return size + struct.pack("<I", crc32(size)) + payload + struct.pack("<I", crc32(payload))


def log_file(path: Path, version: int, payloads: list[bytes],
             header: dict | None = None) -> Path:
    """A log of `version` holding `payloads`, its header line changed by `header`."""
    line = json.dumps({"format": "cavesim-frame-log", "version": version,
                       "session": SESSION, **(header or {})})
    path.write_bytes(line.encode() + b"\n" + b"".join(framed(p) for p in payloads))
    return path


def written(path: Path, frames: list[tuple[FrameMessage, str, int]]) -> bytes:
    writer = FrameLogWriter(path, {"session": SESSION, "scene": "s.toml"})
    for frame in frames:
        writer.append(*frame)
    writer.close()
    return path.read_bytes()


def test_a_version_4_record_is_the_documented_layout_and_reads_back(tmp_path):
    """Every field, a reset and parameters: the writer's bytes are the layout's, byte for
    byte, and read back to the same frame."""
    plain = FrameMessage(8, FrameInput(np.float32(0.02), np.eye(3)))
    frames = [(FULL, DIGEST, 1234), (plain, "ff" * 16, 0)]
    data = written(tmp_path / "frames.log", frames)
    head = data[:data.index(b"\n") + 1]
    assert json.loads(head) == {"format": "cavesim-frame-log", "version": 4,
                                "session": SESSION, "scene": "s.toml"}
    assert data[len(head):] == framed(v4_payload(FULL)) + framed(v4_payload(plain, "ff" * 16,
                                                                            0))
    header, logged = read_frame_log(tmp_path / "frames.log")
    assert header["version"] == VERSION == 4 and logged.damage is None
    assert [comparable(f) for f in logged] == [comparable(LoggedFrame(*f)) for f in frames]
    assert [f.message.reset for f in logged] == [True, False]


@given(message=frame_messages, reset=st.booleans(), digest=digests,
       particles=st.integers(0, 2**32 - 1))
def test_any_frame_round_trips_through_a_version_4_record(message, reset, digest, particles):
    logged = LoggedFrame(replace(message, reset=reset), digest, particles)
    payload = write_record(logged.message, digest, particles)
    assert payload == v4_payload(logged.message, digest, particles)
    assert comparable(read_record(payload)) == comparable(logged)


@pytest.mark.parametrize(("change", "message"), [
    (dict(digest="00" * 15), "digest must be 32 hex digits, got '000000"),
    (dict(digest="zz" * 16), "digest must be 32 hex digits"),
    (dict(particles=2**32), r"particles must be in \[0, 2\*\*32\), got 4294967296"),
    (dict(message=replace(FULL, params=(0.0,) * 33)), "at most 32 scene parameters, got 33"),
])
def test_a_record_refuses_what_it_cannot_hold_by_name(change, message):
    with pytest.raises(ValueError, match=message):
        write_record(**{"message": FULL, "digest": DIGEST, "particles": 1, **change})


def test_the_wire_moving_on_changes_no_byte_of_a_version_4_log(tmp_path, monkeypatch):
    """A log's bytes do not depend on the wire's version or its frame layout: with the
    wire at the next version, speaking a frame layout without events, the writer writes
    the same bytes and they read the same, and so does a version 3 log; the wire itself
    did change."""
    frames = [(FULL, DIGEST, 1234), (replace(FULL, frame=8, reset=False), DIGEST, 1235)]
    before = written(tmp_path / "before.log", frames)
    old = log_file(tmp_path / "old.log", 3, [v3_payload(m, 12, digest, particles)
                                             for m, digest, particles in frames])
    wire_before = encode(replace(FULL, reset=False), SESSION)
    monkeypatch.setattr(envelope, "VERSION", envelope.VERSION + 1)
    monkeypatch.setattr(from_master, "WIRE_FRAME",
                        from_master.FrameLayout("next wire frame", events=False))
    assert encode(replace(FULL, reset=False), SESSION) != wire_before
    assert written(tmp_path / "after.log", frames) == before
    for path in (tmp_path / "after.log", old):
        _, logged = read_frame_log(path)
        assert [comparable(f) for f in logged] == [comparable(LoggedFrame(*f)) for f in frames]


@pytest.mark.parametrize("wire", WIRE_VERSIONS)
def test_a_version_3_log_of_each_wire_version_reads(tmp_path, wire):
    """As the version 3 writer wrote them: frames of wire versions before 11 have no events
    byte (and no reset); from 11 on the byte is there, and a reset reads back."""
    reset = wire >= EVENTS_SINCE
    frames = [(replace(FULL, frame=1, reset=False), DIGEST, 10),
              (replace(FULL, frame=2, reset=reset), "ab" * 16, 11),
              (FrameMessage(3, FrameInput(np.float32(1 / 60), np.eye(3))), "cd" * 16, 12)]
    path = log_file(tmp_path / "frames.log", 3, [v3_payload(m, wire, digest, particles)
                                                 for m, digest, particles in frames])
    header, logged = read_frame_log(path)
    assert header["version"] == 3 and logged.damage is None and len(logged) == 3
    assert [comparable(f) for f in logged] == [comparable(LoggedFrame(*f)) for f in frames]


def test_a_version_3_log_written_by_the_last_writer_reads(tmp_path, monkeypatch):
    """The envelope the old writer took from the wire's encoder (wire version 12, header
    and frame layout as today) is what the crafted records hold."""
    monkeypatch.setattr(envelope, "VERSION", 12)
    message = replace(FULL, reset=False)
    old = encode(message, SESSION) + bytes.fromhex(DIGEST) + struct.pack("<I", 1234)
    assert old == v3_payload(message, 12)
    _, logged = read_frame_log(log_file(tmp_path / "frames.log", 3, [old]))
    assert [comparable(f) for f in logged] == [comparable(LoggedFrame(message, DIGEST, 1234))]


@pytest.mark.parametrize(("payload", "told"), [
    (v3_payload(FULL, 13), "a frame of wire version 13: a version 3 frame log holds wire "
                           "versions 4 to 12"),
    (v3_payload(replace(FULL, reset=False), 3), "a frame of wire version 3"),
    (v3_payload(FULL, 12, session="other"), "session id 0x[0-9a-f]+ is not that of the "
                                            "session the header names"),
    (v3_payload(FULL, 12, kind=3), "magic b'CVSM', kind 3, flags 0x0, reserved 0x0: a "
                                   "version 3 record holds an unsigned frame message"),
    (v3_payload(FULL, 12, flags=1), "magic b'CVSM', kind 1, flags 0x1"),
    (as_wire(v3_payload(FULL, 12), 10), "bad-payload: wire 4-10 frame payload announces 4 "
                                        "parameters in 135 bytes"),
    (v3_payload(FULL, 12)[:40], "40 bytes, a version 3 record is at least 56"),
])
def test_a_version_3_record_it_cannot_read_is_one_line_naming_the_record(tmp_path, payload,
                                                                        told):
    good = v3_payload(replace(FULL, frame=1, reset=False), 12)
    path = log_file(tmp_path / "frames.log", 3, [good, payload])
    _, logged = read_frame_log(path)
    frames = iter(logged)
    assert next(frames).message.frame == 1
    at = len(path.read_bytes()) - len(framed(payload))
    with pytest.raises(FrameLogError, match=f"^{re.escape(str(path))}: the record at byte "
                                            f"{at} passes its checks but does not read: "
                                            f"{told}"):
        next(frames)


def test_a_version_4_record_it_cannot_read_is_one_line_naming_the_record(tmp_path):
    bad = bytearray(v4_payload(FULL))
    bad[-21] = 0x02  # the events byte: no such event
    path = log_file(tmp_path / "frames.log", 4, [v4_payload(FULL), bytes(bad)])
    with pytest.raises(FrameLogError, match=r"the record at byte \d+ passes its checks but "
                                            r"does not read: bad-value: frame events 0x02"):
        list(read_frame_log(path)[1])


def test_a_torn_version_3_log_keeps_its_whole_records(tmp_path):
    payloads = [v3_payload(replace(FULL, frame=k, reset=False), 10) for k in (1, 2, 3)]
    path = log_file(tmp_path / "frames.log", 3, payloads)
    data = path.read_bytes()
    path.write_bytes(data[:-7])
    start = len(data) - len(framed(payloads[-1]))
    _, logged = read_frame_log(path)
    assert [f.message.frame for f in logged] == [1, 2]
    assert logged.damage == Damage(TORN, start, len(framed(payloads[-1])) - 7, 2)


@pytest.mark.parametrize(("header", "told"), [
    ({"version": 2}, "cavesim-frame-log version 2; this build reads versions 3 and 4 "
                     r"\(a version 1 or 2 log is replayed by the build that wrote it\)$"),
    ({"version": 1}, "cavesim-frame-log version 1; this build reads versions 3 and 4"),
    ({"version": 5}, "cavesim-frame-log version 5; this build reads versions 3 and 4"),
    ({"version": 3.0}, "cavesim-frame-log version 3.0; this build reads"),
    ({"version": "4"}, "cavesim-frame-log version '4'; this build reads"),
    ({"format": "other"}, "format 'other', expected 'cavesim-frame-log'$"),
    ({"version": 3, "session": None}, "a version 3 frame log's header must name its "
                                      "session, got session=None$"),
])
def test_a_log_of_another_version_is_refused_in_one_line(tmp_path, header, told):
    path = log_file(tmp_path / "frames.log", 4, [v4_payload(FULL)], header)
    with pytest.raises(FrameLogError, match=f"^{re.escape(str(path))}: {told}"):
        read_frame_log(path)


def test_the_writer_owns_the_header_lines_format_and_version(tmp_path):
    """A header copied from an older log (as a tool re-writing a log does) does not make
    the new log claim its version."""
    writer = FrameLogWriter(tmp_path / "frames.log", {"format": "cavesim-frame-log",
                                                      "version": 3, "session": SESSION})
    writer.append(FULL, DIGEST, 1)
    writer.close()
    header, logged = read_frame_log(tmp_path / "frames.log")
    assert header["version"] == 4 and [comparable(f) for f in logged] == \
        [comparable(LoggedFrame(FULL, DIGEST, 1))]
