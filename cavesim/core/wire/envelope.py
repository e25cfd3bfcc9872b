"""The envelope around every message between master and wall nodes: the header, the
signatures, and the table of payload kinds (their layouts are in `payloads/`).

Every message: a 36-byte header (magic, version, kind, flags, session id, run id, frame
number, payload length) and the payload; in a session with credentials
(`credentials.py`), the master's own kinds (frames, commands, info requests) then carry
the master's Ed25519 signature, a member's message its card (role, name, public
key, the master's certificate) and its own Ed25519 signature, and every message ends with
an HMAC-SHA256 of all that under the session's secret. The envelope says who signed
(`Envelope.signer`); a receiver checks that it is whom the message speaks for
(`Envelope.check_signer`). The run id is the master's, drawn when its run starts: a
message of another run (a replay) is refused by its receiver. A node's state never
travels in one message: a snapshot is a header and chunks (see snapshot.py); blocks of
the checksum's tree and single records travel in bounded block replies. `decode`
checks everything before trusting anything and raises `ProtocolError` with a short reason
the receivers count; it never returns a half-checked message.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from enum import IntEnum
from typing import NamedTuple

from cavesim.core.errors import ProtocolError
from cavesim.core.wire.credentials import (
    MASTER_IDENTITY,
    MASTER_SIGNATURE_BYTES,
    Credentials,
    Identity,
    read_card,
)
from cavesim.core.wire.payloads import from_master, from_nodes, poses, state_transfer
from cavesim.core.wire.payloads.from_master import ControlMessage, FrameMessage, InfoRequest
from cavesim.core.wire.payloads.from_nodes import DisplayMessage, InfoMessage, ReportMessage
from cavesim.core.wire.payloads.poses import TrackingMessage
from cavesim.core.wire.payloads.state_transfer import (
    BlockReply,
    BlockRequest,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
)

MAGIC = b"CVSM"
VERSION = 15  # 2: frames carry the head pose; 3: snapshots stream as a header and chunks,
# a node's info (its GPU, whether it is swap-locked) answers a query, and displaying walls
# take part in the swap barrier; 4: a run id in the header, the master's signature, requests
# (block requests and replies came later as new kinds, which an older build refuses as such);
# 5: a report may end in a drift sample (the mixed-hardware tolerance mode); 6: a particle
# record's last word carries the position's low part beside the class (a snapshot or block
# reply, which an older build would read as a class); 7: a wall's or tracker's card and own
# signature, a tracking message's send time, and requests that end in a fresh nonce (state
# and block requests also name their asker); 8: a report times each phase of the node's
# frame (cavesim/core/frame_cost.py) in place of its step and checksum; 9: it times its
# GPU passes and its wait for the GPU too; 10: it counts the particles of each class that
# left the field's box, and a frame of a time-series field ends in the field's time; 11: it
# counts the new particles the full capacity dropped, a frame ends in a byte of events (a
# reset), and a tracking message may carry the preview's session controls (pause, reset, quit);
# 12: it counts its adaptive tracers' substeps (frames as in 11); 13: a report is a fixed
# core and a tagged tail of counters (cavesim/core/counters.py: id, value count, values), an
# id its receiver does not know skipped, so a new counter moves this version no more (frames
# as in 11); 14: a card may name an operator, the only member whose session controls count;
# 15: a RESYNC names the wall that confirms the state, which a block request may ask for
# the cryptographic digest of records (DIGEST)
HEADER = struct.Struct("<4sBBBBQQQI")  # magic, version, kind, flags, reserved (0), ...
# Only VERSION is spoken or read. A frame log keeps its frames in layouts of its own and
# reads its older records itself (cavesim.core.framelog), so VERSION moves without it.
SIGNATURE_BYTES = 32
SIGNED, MASTER_SIGNED, MEMBER_SIGNED = 0x01, 0x02, 0x04


class Kind(IntEnum):
    FRAME = 1
    REPORT = 2
    CONTROL = 3
    SNAPSHOT = 4
    TRACKING = 5
    CHUNK = 6
    INFO = 7
    DISPLAY = 8
    INFO_REQUEST = 9
    STATE_REQUEST = 10
    BLOCK_REQUEST = 11
    BLOCK_REPLY = 12


MASTER_KINDS = frozenset({Kind.FRAME, Kind.CONTROL, Kind.INFO_REQUEST})  # the master signs


class PayloadFormat(NamedTuple):
    """A kind's message, and the functions that write and read its payload."""

    message: type
    write: Callable[[Message], bytes]
    read: Callable[[int, bytes], Message]  # (the header's frame, the payload)


Message = (FrameMessage | ReportMessage | ControlMessage | SnapshotHeader | SnapshotChunk
           | TrackingMessage | InfoMessage | DisplayMessage | InfoRequest | StateRequest
           | BlockRequest | BlockReply)
_PAYLOADS = {
    Kind.FRAME: PayloadFormat(
        FrameMessage, from_master.write_frame, from_master.read_frame),
    Kind.REPORT: PayloadFormat(
        ReportMessage, from_nodes.write_report, from_nodes.read_report),
    Kind.CONTROL: PayloadFormat(
        ControlMessage, from_master.write_control, from_master.read_control),
    Kind.SNAPSHOT: PayloadFormat(
        SnapshotHeader, state_transfer.write_snapshot, state_transfer.read_snapshot),
    Kind.TRACKING: PayloadFormat(
        TrackingMessage, poses.write_tracking, poses.read_tracking),
    Kind.CHUNK: PayloadFormat(
        SnapshotChunk, state_transfer.write_chunk, state_transfer.read_chunk),
    Kind.INFO: PayloadFormat(
        InfoMessage, from_nodes.write_info, from_nodes.read_info),
    Kind.DISPLAY: PayloadFormat(
        DisplayMessage, from_nodes.write_display, from_nodes.read_display),
    Kind.INFO_REQUEST: PayloadFormat(
        InfoRequest, from_master.write_info_request, from_master.read_info_request),
    Kind.STATE_REQUEST: PayloadFormat(
        StateRequest, state_transfer.write_state_request, state_transfer.read_state_request),
    Kind.BLOCK_REQUEST: PayloadFormat(
        BlockRequest, state_transfer.write_block_request, state_transfer.read_block_request),
    Kind.BLOCK_REPLY: PayloadFormat(
        BlockReply, state_transfer.write_block_reply, state_transfer.read_block_reply),
}
_KINDS = {payload.message: kind for kind, payload in _PAYLOADS.items()}


@dataclass(frozen=True)
class Envelope:
    """A checked message and what its header said of it."""

    message: Message
    run_id: int  # the run it belongs to (0: none)
    signer: Identity | None  # whose valid signature it carries (None: nobody's)
    keyed: bool = False  # it was checked against the session's credentials

    @property
    def from_master(self) -> bool:
        """It carries the master's valid signature."""
        return self.signer == MASTER_IDENTITY

    def check_signer(self, role: str, name: str) -> None:
        """ProtocolError `wrong-signer` unless a keyed message is signed by the member
        `role` `name` (the one it speaks for); without keys nobody signs, and nothing is
        checked."""
        if self.keyed and self.signer != Identity(role, name):
            raise ProtocolError("wrong-signer", f"a {type(self.message).__name__} for "
                                                f"{role} {name} signed by "
                                                f"{self.signer or 'no member'}")


RUN_RANDOM_BITS = 22  # below the start time's milliseconds: 4 million ids per millisecond


def new_run_id(now_ns: int | None = None) -> int:
    """A run's id: the milliseconds since the Unix epoch at which it starts (`now_ns`, by
    default this host's clock), then RUN_RANDOM_BITS random bits. An earlier run's id is
    smaller (two masters that meet keep the one that started first) and two runs' ids
    differ; never 0, which means "no run"."""
    now_ns = time.time_ns() if now_ns is None else now_ns
    started = (now_ns // 1_000_000) % (1 << (64 - RUN_RANDOM_BITS))
    return (started << RUN_RANDOM_BITS | secrets.randbits(RUN_RANDOM_BITS)) or 1


def run_started(run_id: int) -> str:
    """When the run of `run_id` started, in UTC, to the millisecond (as its master's host
    told the time)."""
    started = datetime.fromtimestamp((run_id >> RUN_RANDOM_BITS) / 1000, UTC)
    return started.strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] + " UTC"


def session_id(session: str) -> int:
    """64-bit id of a session name, carried in every header."""
    return int.from_bytes(hashlib.blake2b(session.encode(), digest_size=8).digest(), "little")


def encode(message: Message, session: str, credentials: Credentials | None = None,
           run_id: int = 0) -> bytes:
    """The message's bytes: with credentials, signed (and a master kind signed by the
    master, whose credentials must hold the signing key; any other kind by the member whose
    credentials they are, if they name one)."""
    if not 0 <= message.frame < 2**64 or not 0 <= run_id < 2**64:
        raise ValueError(f"frame and run id must be in [0, 2**64), got {message.frame} and "
                         f"{run_id}")
    kind = _KINDS[type(message)]
    payload = _PAYLOADS[kind].write(message)
    by_master = credentials is not None and kind in MASTER_KINDS
    by_member = credentials is not None and not by_master and credentials.card is not None
    flags = (SIGNED | (MASTER_SIGNED if by_master else 0) | (MEMBER_SIGNED if by_member else 0)
             ) if credentials is not None else 0
    data = HEADER.pack(MAGIC, VERSION, kind, flags, 0, session_id(session), run_id,
                       message.frame, len(payload)) + payload
    if credentials is None:
        return data
    if by_master:
        data += credentials.sign_as_master(data)
    if by_member:
        data += credentials.card + credentials.sign_as_member(data)
    return data + _signature(credentials.secret, data)


def decode(data: bytes, session: str, credentials: Credentials | None = None) -> Message:
    """Check and parse one message of `session`; ProtocolError names what is wrong."""
    return decode_envelope(data, session, credentials).message


def decode_envelope(data: bytes, session: str,
                    credentials: Credentials | None = None) -> Envelope:
    """Check and parse one message of `session`, keeping its run id; ProtocolError names
    what is wrong. With credentials, every message must carry the session's HMAC and the
    master's kinds the master's signature; a member's card and signature must verify."""
    data = bytes(data)
    if len(data) < HEADER.size:
        raise ProtocolError("truncated", f"{len(data)} bytes, a header alone is {HEADER.size}")
    magic, version, kind, flags, reserved, sid, run_id, frame, length = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise ProtocolError("bad-magic", f"starts with {magic!r}, expected {MAGIC!r}")
    if version != VERSION:
        raise ProtocolError("bad-version", f"version {version}, this build speaks {VERSION}")
    if kind not in Kind.__members__.values():
        raise ProtocolError("bad-kind", f"kind {kind}, expected one of {[k.value for k in Kind]}")
    if sid != session_id(session):
        raise ProtocolError("wrong-session", f"session id {sid:#x} is not {session!r}'s")
    allowed = (0, SIGNED, SIGNED | (MASTER_SIGNED if kind in MASTER_KINDS else MEMBER_SIGNED))
    if flags not in allowed or reserved:
        raise ProtocolError("bad-flags", f"flags {flags:#x} and reserved byte {reserved:#x}; "
                                         f"allowed for a {Kind(kind).name.lower()}: "
                                         f"{', '.join(f'{a:#x}' for a in allowed)}, "
                                         f"reserved 0")
    end = HEADER.size + length  # of the body
    card_end = _card_end(data, end) if flags & MEMBER_SIGNED else end
    trailer = (SIGNATURE_BYTES if flags & SIGNED else 0) \
        + (MASTER_SIGNATURE_BYTES if flags & (MASTER_SIGNED | MEMBER_SIGNED) else 0)
    if len(data) != card_end + trailer:
        raise ProtocolError("bad-length", f"{len(data)} bytes, the header announces "
                                          f"{card_end + trailer}")
    signer = None
    if credentials is not None:
        if not flags & SIGNED:
            raise ProtocolError("unsigned", "the session requires an HMAC and none is attached")
        body = data[:end]
        signed, signature = data[:-SIGNATURE_BYTES], data[-SIGNATURE_BYTES:]
        if not hmac.compare_digest(signature, _signature(credentials.secret, signed)):
            raise ProtocolError("bad-signature", "the HMAC does not match the session's key")
        if flags & MASTER_SIGNED:
            if not credentials.is_masters(body, signed[len(body):]):
                raise ProtocolError("bad-master-signature", "the master's signature does not "
                                                            "match the session's master key")
            signer = MASTER_IDENTITY
        if flags & MEMBER_SIGNED:
            signer = credentials.signer_of(signed[len(body):card_end], body,
                                           signed[card_end:])
            if signer is None:
                raise ProtocolError("bad-member-signature", "the sender's card is not the "
                                                            "master's, or its signature does "
                                                            "not match the card's key")
        if kind in MASTER_KINDS and signer != MASTER_IDENTITY:
            raise ProtocolError("not-from-master", f"a {Kind(kind).name.lower()} message "
                                                   f"without the master's signature")
    elif flags:
        raise ProtocolError("unexpected-signature", "signed message, but the session has no key")
    payload = data[HEADER.size:HEADER.size + length]
    return Envelope(_PAYLOADS[Kind(kind)].read(frame, payload), run_id, signer,
                    credentials is not None)


def _card_end(data: bytes, start: int) -> int:
    """Where the member's card after the body ends; ProtocolError if there is none."""
    card = read_card(data, start)
    if card is None:
        raise ProtocolError("bad-length", f"{len(data) - start} bytes after the body are not "
                                          f"a member's card and signature")
    return card[3]


def _signature(secret: bytes, data: bytes) -> bytes:
    return hmac.new(secret, data, hashlib.sha256).digest()
