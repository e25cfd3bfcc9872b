"""A frame log's record of version 4, the one this build writes: the frame in a layout the
log names itself, then what the cluster agreed on after it.

    payload = u64 frame number | the frame's fields in RECORD_FRAME | 16-byte agreed digest
              | u32 live particle count
    RECORD_FRAME = u32 dt (float32 bits) | 9 f32 random-texture matrix (row-major) |
                   3 f32 head position | 4 f32 head orientation | 3 f32 wand position |
                   4 f32 wand orientation | u32 buttons | 4 f32 axes | u16 n |
                   n f32 scene parameters | u8 events (0x01: reset)

all little-endian. No wire header, session id or signature: the header line names the
session, and a record is checked by its CRC (log_file.py). The fields are written and read
by the frame codec the wire uses too (`cavesim.core.wire.payloads.from_master`), in
RECORD_FRAME, a layout named here: the wire speaks its own `WIRE_FRAME`, and a change of
the wire's frame moves only that one, so what this record holds stays as it is whatever the
wire's version (the tests pin these bytes). A change of this record is a new log version
with a reader of its own in `log_file.READERS`; this one then reads the older logs.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

from cavesim.core.wire.payloads.from_master import (
    FrameLayout,
    FrameMessage,
    read_frame_fields,
    write_frame_fields,
)

VERSION = 4
RECORD_FRAME = FrameLayout("version 4 frame record", events=True)
_NUMBER = struct.Struct("<Q")  # the frame number
_DIGEST_BYTES = 16
_TAIL = struct.Struct(f"<{_DIGEST_BYTES}sI")  # the agreed digest and live particle count


@dataclass(frozen=True)
class LoggedFrame:
    """A logged frame: its inputs, and the checksum and live count the walls agreed on
    after stepping it."""

    message: FrameMessage
    digest: str  # 32 lower-case hex digits
    particles: int


def write_record(message: FrameMessage, digest: str, particles: int) -> bytes:
    """The record's payload; ValueError names a value that does not fit it."""
    if not 0 <= message.frame < 2**64:
        raise ValueError(f"frame must be in [0, 2**64), got {message.frame}")
    try:
        digest_bytes = bytes.fromhex(digest)
    except ValueError:
        digest_bytes = b""
    if len(digest_bytes) != _DIGEST_BYTES:
        raise ValueError(f"digest must be 32 hex digits, got {digest!r}")
    if not 0 <= particles < 2**32:
        raise ValueError(f"particles must be in [0, 2**32), got {particles}")
    return _NUMBER.pack(message.frame) + write_frame_fields(RECORD_FRAME, message) \
        + _TAIL.pack(digest_bytes, particles)


def read_record(payload: bytes) -> LoggedFrame:
    """The logged frame a record's payload holds; ValueError (a ProtocolError for the
    frame's fields) says what is wrong."""
    if len(payload) < _NUMBER.size + _TAIL.size:
        raise ValueError(f"{len(payload)} bytes, a version {VERSION} record is at least "
                         f"{_NUMBER.size + _TAIL.size} and the frame's fields")
    (frame,) = _NUMBER.unpack_from(payload)
    digest, particles = _TAIL.unpack_from(payload, len(payload) - _TAIL.size)
    message = read_frame_fields(RECORD_FRAME, frame,
                                payload[_NUMBER.size:len(payload) - _TAIL.size])
    return LoggedFrame(message, digest.hex(), particles)


def record_reader(header: dict) -> Callable[[bytes], LoggedFrame]:
    """How a version 4 log's records read: each on its own, nothing of the header needed."""
    return read_record
