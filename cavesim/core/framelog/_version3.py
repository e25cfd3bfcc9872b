"""Reading a frame log of version 3, which this build no longer writes: each record held
the frame message as the master sent it, an unsigned wire envelope of wire version 4 to 12.

    payload = envelope header | the frame's fields | 16-byte agreed digest | u32 live count
    envelope header (36 bytes) = "CVSM" | u8 wire version | u8 kind (1: a frame) |
        u8 flags (0: unsigned) | u8 reserved (0) | u64 session id | u64 run id |
        u64 frame number | u32 length of the frame's fields

all little-endian; the session id is the first 8 bytes of BLAKE2b of the header's session
name, read as a little-endian integer. The fields are the wire's frame payload of that
version: from wire version 11 on they end in a byte of events (0x01: reset); before, they
had none, and no reset happened. Every fact of this format is spelled out here rather than
taken from the wire, which has moved on, so that these logs read the same whatever the wire
speaks next; the fields alone are read by the frame codec, in layouts named here.
"""

from __future__ import annotations

import hashlib
import struct
from collections.abc import Callable

from cavesim.core.framelog.version4 import LoggedFrame
from cavesim.core.wire.payloads.from_master import FrameLayout, read_frame_fields

VERSION = 3
_ENVELOPE = struct.Struct("<4sBBBBQQQI")  # magic, version, kind, flags, reserved, session
# id, run id, frame number, length of the fields
_MAGIC, _FRAME_KIND = b"CVSM", 1
_TAIL = struct.Struct("<16sI")  # the agreed digest and live particle count
_BEFORE_EVENTS = FrameLayout("wire 4-10 frame payload", events=False)
_WITH_EVENTS = FrameLayout("wire 11-12 frame payload", events=True)
LAYOUTS = {**dict.fromkeys(range(4, 11), _BEFORE_EVENTS), 11: _WITH_EVENTS,
           12: _WITH_EVENTS}  # the frame layout of each wire version a record may hold


def record_reader(header: dict) -> Callable[[bytes], LoggedFrame]:
    """How the records of a version 3 log with this header read; ValueError if the header
    names no session (each record's envelope carries its id)."""
    session = header.get("session")
    if not isinstance(session, str):
        raise ValueError(f"a version {VERSION} frame log's header must name its session, "
                         f"got session={session!r}")
    session_id = int.from_bytes(hashlib.blake2b(session.encode(), digest_size=8).digest(),
                                "little")
    return lambda payload: read_record(payload, session_id)


def read_record(payload: bytes, session_id: int) -> LoggedFrame:
    """The logged frame a version 3 record's payload holds; ValueError (a ProtocolError
    for the frame's fields) says what is wrong."""
    if len(payload) < _ENVELOPE.size + _TAIL.size:
        raise ValueError(f"{len(payload)} bytes, a version {VERSION} record is at least "
                         f"{_ENVELOPE.size + _TAIL.size} and the frame's fields")
    magic, version, kind, flags, reserved, sid, _run_id, frame, length = \
        _ENVELOPE.unpack_from(payload)
    fields = payload[_ENVELOPE.size:len(payload) - _TAIL.size]
    if (magic, kind, flags, reserved) != (_MAGIC, _FRAME_KIND, 0, 0):
        raise ValueError(f"magic {magic!r}, kind {kind}, flags {flags:#x}, reserved "
                         f"{reserved:#x}: a version {VERSION} record holds an unsigned frame "
                         f"message (magic {_MAGIC!r}, kind {_FRAME_KIND}, flags and reserved 0)")
    if version not in LAYOUTS:
        raise ValueError(f"a frame of wire version {version}: a version {VERSION} frame log "
                         f"holds wire versions {min(LAYOUTS)} to {max(LAYOUTS)}")
    if sid != session_id:
        raise ValueError(f"session id {sid:#x} is not that of the session the header names")
    if length != len(fields):
        raise ValueError(f"its envelope announces {length} bytes of fields, the record "
                         f"holds {len(fields)}")
    digest, particles = _TAIL.unpack_from(payload, len(payload) - _TAIL.size)
    return LoggedFrame(read_frame_fields(LAYOUTS[version], frame, fields), digest.hex(),
                       particles)
