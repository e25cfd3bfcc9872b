"""Versioned fixed binary layouts of the messages between master and wall nodes.

Every message: a 36-byte header (magic, version, kind, flags, session id, run id, frame
number, payload length) and the payload; in a session with credentials
(`credentials.py`), the master's own kinds (frames, commands, info requests) then carry
the master's Ed25519 signature, and every message ends with an HMAC-SHA256 of all that
under the session's secret. The run id is the master's, drawn when its run starts: a
message of another run (a replay) is refused by its receiver. A node's state never
travels in one message: a snapshot is a header and chunks (see snapshot.py); blocks of
the checksum's tree and single records travel in bounded block replies. `decode`
checks everything before trusting anything and raises `ProtocolError` with a short reason
the receivers count; it never returns a half-checked message.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import secrets
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from cavesim.core.digest.history import HISTORY_FRAMES
from cavesim.core.digest.shape import ITEM_WORDS, RECORD_WORDS
from cavesim.core.drift import MAX_SAMPLE, SAMPLE_DTYPE, DriftSample
from cavesim.core.errors import ProtocolError
from cavesim.core.frame import FrameInput
from cavesim.core.limits import MAX_EMITTERS, MAX_PARTICLES
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.wire.credentials import MASTER_SIGNATURE_BYTES, Credentials
from cavesim.core.wire.key_expressions import check_name

MAGIC = b"CVSM"
VERSION = 6  # 2: frames carry the head pose; 3: snapshots stream as a header and chunks,
# a node's info (its GPU, whether it is swap-locked) answers a query, and displaying walls
# take part in the swap barrier; 4: a run id in the header, the master's signature, requests
# (block requests and replies came later as new kinds, which an older build refuses as such);
# 5: a report may end in a drift sample (the mixed-hardware tolerance mode); 6: a particle
# record's last word carries the position's low part beside the class (a snapshot or block
# reply, which an older build would read as a class)
HEADER = struct.Struct("<4sBBBBQQQI")  # magic, version, kind, flags, reserved (0), ...
SIGNATURE_BYTES = 32
SIGNED, MASTER_SIGNED = 0x01, 0x02
MAX_PARAMS = 32
MAX_TEXT = 255  # characters of one string of an info message (a one-byte length)
MAX_CHUNK_PARTICLES = 2**26 // PARTICLE_BYTES  # 64 MiB, far below zenoh's 1 GiB messages

_FRAME = struct.Struct("<I9f3f4f3f4fI4fH")  # dt bits, matrix, head, wand, buttons, axes, n
_REPORT = struct.Struct("<16sIIIIIB")  # digest, counts, step+checksum us, rejected, status
_SAMPLE = struct.Struct("<H")  # records of a report's drift sample, then the records
_SNAPSHOT = struct.Struct("<QIII16s")  # seed, particles, emitters, chunk particles, digest
_CHUNK = struct.Struct("<I")  # chunk index, then whole particle records
_TRACKING = struct.Struct("<3f4f3f4fI4f")  # head, wand pose, buttons, axes
_INFO = struct.Struct("<HBQ")  # EGL device index, flags, join nonce; then three strings
INFO_SOFTWARE, INFO_SWAP_LOCKED = 0x01, 0x02
_DISPLAY = struct.Struct("<BQ")  # phase, the node's monotonic clock in ns
_CONTROL_TAIL = struct.Struct("<16sQ")  # the named state's digest (RESYNC), nonce (WELCOME)
_STATE_REQUEST = struct.Struct("<16s")  # the digest of the state asked for
_BLOCK_REQUEST = struct.Struct("<16sBBI")  # digest, query, part, index count; then indices
_BLOCK_REPLY = struct.Struct("<BBQIIB")  # query, part, seed, counts, history frames
_HISTORY_FRAME = struct.Struct("<QII")  # frame, particles, emitters
MAX_BLOCK_INDICES = 16_384  # items or records one block request names (64 KiB)
MAX_BLOCK_BYTES = 4 * 2**20  # of a block reply's data, like a snapshot's chunk


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


class Command(IntEnum):
    RESYNC = 1  # target loads `source`'s state of the frame, whose checksum is `digest`
    STOP = 2  # every node ends cleanly
    SWAP = 3  # every swap-locked wall has drawn the frame: show it
    WELCOME = 4  # target joins this run (the header's run id); `nonce` is its own, fresh


class Status(IntEnum):
    STEPPED = 0  # the node stepped this frame
    RESYNCED = 1  # the node loaded a snapshot of this frame
    REPEATED = 2  # a repeat of an earlier report (the frame came again)
    JOINED = 3  # the node took the run's WELCOME: it holds the scene's start state
    BEHIND = 4  # the node holds `frame`, older than the cluster's: it asks for a resync


@dataclass(frozen=True)
class WandState:
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # quaternion xyzw
    buttons: int = 0
    axes: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class HeadState:
    position: tuple[float, float, float] = (0.0, 0.0, 1.7)  # room metres, eyes' midpoint
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # quaternion xyzw


@dataclass(frozen=True)
class FrameMessage:
    frame: int
    inputs: FrameInput
    wand: WandState = WandState()
    params: tuple[float, ...] = ()  # the scene's time-varying parameters
    head: HeadState = HeadState()  # tracked or scripted, sampled once by the master


@dataclass(frozen=True)
class ReportMessage:
    frame: int
    node: str
    digest: str  # 32 hex digits
    particles: int
    emitters: int
    step_us: int
    checksum_us: int
    rejected: int = 0  # messages this node has rejected so far
    status: Status = Status.STEPPED
    sample: DriftSample | None = None  # mixed-hardware mode: its records sample_indices names


@dataclass(frozen=True)
class ControlMessage:
    frame: int
    command: Command
    target: str = ""
    source: str = ""
    digest: str = ""  # RESYNC: the checksum of the state to load (32 hex digits)
    nonce: int = 0  # WELCOME: the nonce the target last sent in its info


@dataclass(frozen=True)
class InfoRequest:
    """The master's question to a node: which GPU do you compute on, and your nonce?"""

    frame: int
    node: str


@dataclass(frozen=True)
class StateRequest:
    """A resyncing node's query for `node`'s state of `frame`, whose checksum is `digest`."""

    frame: int
    node: str
    digest: str


class BlockQuery(IntEnum):
    """What a block request asks a node for, of the state it holds (`part` says which)."""

    TREE = 1  # items of one level of the checksum's tree (part: the level, 0 sums, 1, 2),
    # with the state's seed and counts; no indices: the whole level
    HISTORY = 2  # fold-1 items (part 1) of every frame its history ring holds up to `frame`
    RECORDS = 3  # whole records of one stream (part: 0 particles, 1 emitters)


_PARTS = {BlockQuery.TREE: (0, 1, 2), BlockQuery.HISTORY: (1,), BlockQuery.RECORDS: (0, 1)}


@dataclass(frozen=True)
class BlockRequest:
    """A question about `node`'s state of `frame`, whose checksum is `digest` (a node that
    holds another state refuses it): the master's forensics, or a resyncing node's delta."""

    frame: int
    node: str
    digest: str
    query: BlockQuery
    part: int
    indices: tuple[int, ...] = ()  # ascending, at most MAX_BLOCK_INDICES


@dataclass(frozen=True)
class HistoryFrame:
    """A frame of a node's history ring, and the live counts of its state then."""

    frame: int
    particles: int
    emitters: int


@dataclass(frozen=True)
class BlockReply:
    """A node's answer to a block request: the items or records asked for, in the order
    asked (HISTORY: frame by frame), with the state's seed and live counts."""

    frame: int
    node: str
    query: BlockQuery
    part: int
    seed: int
    particles: int
    emitters: int
    data: bytes = field(repr=False)
    history: tuple[HistoryFrame, ...] = ()  # HISTORY: the frames of `data`, oldest first

    @property
    def unit(self) -> int:
        """Bytes of one item or record of the reply's data."""
        if self.query is BlockQuery.RECORDS:
            return RECORD_WORDS[self.part] * 4
        return ITEM_WORDS[self.part] * 4


@dataclass(frozen=True)
class SnapshotHeader:
    """The first reply to a state query: the state that the chunks after it add up to."""

    frame: int
    seed: int
    particles: int  # live particles, streamed in chunks of `chunk_particles` records
    chunk_particles: int
    digest: str  # the state's checksum (32 hex digits): the load commits only if it matches
    emitters: np.ndarray = field(repr=False)  # EMITTER_DTYPE, whole: at most 64 KiB

    @property
    def chunks(self) -> int:
        """How many chunks follow (derived, so it cannot disagree with the counts)."""
        return -(-self.particles // self.chunk_particles)


@dataclass(frozen=True)
class SnapshotChunk:
    """Chunk `index` of a snapshot: particles [index x chunk_particles, ...), whole records."""

    frame: int
    index: int
    data: bytes = field(repr=False)


@dataclass(frozen=True)
class TrackingMessage:
    """A tracker's (or a script's, or a keyboard bridge's) latest head and wand state."""

    frame: int  # the sender's own counter; the master ignores it
    head: HeadState
    wand: WandState


@dataclass(frozen=True)
class InfoMessage:
    """A node's answer to the master's info query: the GPU it computes on."""

    frame: int  # the node's last frame when it answered
    node: str
    device: int  # EGL device index
    software: bool  # a CPU renderer (Mesa's llvmpipe), not a GPU
    renderer: str  # GL_RENDERER, GL_VENDOR and GL_VERSION (which names the driver) ...
    vendor: str
    version: str  # ... each printable ASCII, at most MAX_TEXT characters
    swap_locked: bool = False  # it shows frames live and swaps only on the master's SWAP
    nonce: int = 0  # fresh after every WELCOME: only a WELCOME naming it admits the node

    @classmethod
    def of_gpu(cls, frame: int, node: str, gpu: Mapping, swap_locked: bool = False,
               nonce: int = 0) -> InfoMessage:
        """The message for a GPU as `cavesim.gpu.gl.context.gpu_of` describes it; characters
        the wire cannot carry become '?', and long strings are cut to MAX_TEXT."""
        def fit(text: str) -> str:
            return "".join(c if " " <= c <= "~" else "?" for c in text)[:MAX_TEXT]

        return cls(frame, node, gpu["device"], gpu["kind"] == "software", fit(gpu["renderer"]),
                   fit(gpu["vendor"]), fit(gpu["version"]), swap_locked, nonce)

    def gpu(self) -> dict:
        """The GPU as `gpu_of` describes it, for report.json."""
        return {"device": self.device, "kind": "software" if self.software else "hardware",
                "renderer": self.renderer, "vendor": self.vendor, "version": self.version}


class Phase(IntEnum):
    DRAWN = 1  # the wall has drawn the frame into its back buffer
    SWAPPED = 2  # its swap returned: the frame is on the wall


@dataclass(frozen=True)
class DisplayMessage:
    """A displaying wall's step of the swap barrier, with its monotonic clock (ns)."""

    frame: int
    node: str
    phase: Phase
    time_ns: int


Message = (FrameMessage | ReportMessage | ControlMessage | SnapshotHeader | SnapshotChunk
           | TrackingMessage | InfoMessage | DisplayMessage | InfoRequest | StateRequest
           | BlockRequest | BlockReply)


@dataclass(frozen=True)
class Envelope:
    """A checked message and what its header said of it."""

    message: Message
    run_id: int  # the run it belongs to (0: none, e.g. a tracker's)
    from_master: bool  # it carries the master's valid signature


def new_run_id() -> int:
    """A run's id: 64 random bits (never 0, which means "no run")."""
    return secrets.randbits(64) or 1


def session_id(session: str) -> int:
    """64-bit id of a session name, carried in every header."""
    return int.from_bytes(hashlib.blake2b(session.encode(), digest_size=8).digest(), "little")


def encode(message: Message, session: str, credentials: Credentials | None = None,
           run_id: int = 0) -> bytes:
    """The message's bytes: with credentials, signed (and a master kind signed by the
    master, whose credentials must hold the signing key)."""
    if not 0 <= message.frame < 2**64 or not 0 <= run_id < 2**64:
        raise ValueError(f"frame and run id must be in [0, 2**64), got {message.frame} and "
                         f"{run_id}")
    kind, payload = _PAYLOAD_WRITERS[type(message)](message)
    by_master = credentials is not None and kind in MASTER_KINDS
    flags = (SIGNED | (MASTER_SIGNED if by_master else 0)) if credentials is not None else 0
    data = HEADER.pack(MAGIC, VERSION, kind, flags, 0, session_id(session), run_id,
                       message.frame, len(payload)) + payload
    if credentials is None:
        return data
    if by_master:
        data += credentials.sign_as_master(data)
    return data + _signature(credentials.secret, data)


def decode(data: bytes, session: str, credentials: Credentials | None = None) -> Message:
    """Check and parse one message of `session`; ProtocolError names what is wrong."""
    return decode_envelope(data, session, credentials).message


def decode_envelope(data: bytes, session: str,
                    credentials: Credentials | None = None) -> Envelope:
    """Check and parse one message of `session`, keeping its run id; ProtocolError names
    what is wrong. With credentials, every message must carry the session's HMAC and the
    master's kinds the master's signature."""
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
    if flags & ~(SIGNED | MASTER_SIGNED) or reserved or flags == MASTER_SIGNED \
            or flags & MASTER_SIGNED and kind not in MASTER_KINDS:
        raise ProtocolError("bad-flags", f"flags {flags:#x} and reserved byte {reserved:#x}; "
                                         f"allowed: 0, {SIGNED:#x}, {SIGNED | MASTER_SIGNED:#x}"
                                         f" (the second for the master's kinds), reserved 0")
    trailer = (SIGNATURE_BYTES if flags & SIGNED else 0) \
        + (MASTER_SIGNATURE_BYTES if flags & MASTER_SIGNED else 0)
    if len(data) != HEADER.size + length + trailer:
        raise ProtocolError("bad-length", f"{len(data)} bytes, the header announces "
                                          f"{HEADER.size + length + trailer}")
    body = data[:HEADER.size + length]
    from_master = False
    if credentials is not None:
        if not flags & SIGNED:
            raise ProtocolError("unsigned", "the session requires an HMAC and none is attached")
        signed, signature = data[:-SIGNATURE_BYTES], data[-SIGNATURE_BYTES:]
        if not hmac.compare_digest(signature, _signature(credentials.secret, signed)):
            raise ProtocolError("bad-signature", "the HMAC does not match the session's key")
        if flags & MASTER_SIGNED:
            if not credentials.is_masters(body, signed[len(body):]):
                raise ProtocolError("bad-master-signature", "the master's signature does not "
                                                            "match the session's master key")
            from_master = True
        if kind in MASTER_KINDS and not from_master:
            raise ProtocolError("not-from-master", f"a {Kind(kind).name.lower()} message "
                                                   f"without the master's signature")
    elif flags:
        raise ProtocolError("unexpected-signature", "signed message, but the session has no key")
    payload = data[HEADER.size:HEADER.size + length]
    return Envelope(_PAYLOAD_READERS[Kind(kind)](frame, payload), run_id, from_master)


def _signature(secret: bytes, data: bytes) -> bytes:
    return hmac.new(secret, data, hashlib.sha256).digest()


# -- payloads ----------------------------------------------------------------------------

def _write_frame(m: FrameMessage) -> tuple[Kind, bytes]:
    if len(m.params) > MAX_PARAMS:
        raise ValueError(f"at most {MAX_PARAMS} scene parameters, got {len(m.params)}")
    w, h = m.wand, m.head
    values = np.array([*h.position, *h.orientation, *w.position, *w.orientation, *w.axes,
                       *m.params], dtype=np.float64)
    if not np.all(np.isfinite(values)) or np.any(np.abs(values) > np.finfo(np.float32).max):
        raise ValueError(f"head, wand and scene parameters must be finite float32 values, "
                         f"got {h}, {w} and {m.params}")
    dt_bits = int(np.float32(m.inputs.dt).view(np.uint32))
    body = _FRAME.pack(dt_bits, *m.inputs.random_transform.ravel().tolist(), *h.position,
                       *h.orientation, *w.position, *w.orientation, w.buttons, *w.axes,
                       len(m.params))
    return Kind.FRAME, body + np.asarray(m.params, dtype="<f4").tobytes()


def _read_frame(frame: int, payload: bytes) -> FrameMessage:
    if len(payload) < _FRAME.size:
        raise ProtocolError("bad-payload", f"frame payload of {len(payload)} bytes is too short")
    values = _FRAME.unpack_from(payload)
    count = values[-1]
    if count > MAX_PARAMS or len(payload) != _FRAME.size + 4 * count:
        raise ProtocolError("bad-payload", f"frame announces {count} parameters in a payload "
                                           f"of {len(payload)} bytes (at most {MAX_PARAMS})")
    dt = np.array([values[0]], dtype=np.uint32).view(np.float32)[0]
    matrix = np.array(values[1:10], dtype=np.float32).reshape(3, 3)
    head, wand, buttons, axes = values[10:17], values[17:24], values[24], values[25:29]
    params = np.frombuffer(payload, dtype="<f4", offset=_FRAME.size, count=count)
    if not all(math.isfinite(v) for v in (*head, *wand, *axes, *params.tolist())):
        raise ProtocolError("bad-value", "head, wand and scene parameters must be finite")
    try:
        inputs = FrameInput(dt, matrix)
    except ValueError as e:
        raise ProtocolError("bad-value", str(e)) from e
    return FrameMessage(frame, inputs, WandState(wand[:3], wand[3:], buttons, axes),
                        tuple(params.tolist()), HeadState(head[:3], head[3:]))


def _digest_bytes(digest: str) -> bytes:
    if len(digest) != 32 or any(c not in "0123456789abcdef" for c in digest):
        raise ValueError(f"digest must be 32 lower-case hex digits, got {digest!r}")
    return bytes.fromhex(digest)


def _write_report(m: ReportMessage) -> tuple[Kind, bytes]:
    body = _name_bytes(m.node) + _REPORT.pack(
        _digest_bytes(m.digest), m.particles, m.emitters, m.step_us, m.checksum_us, m.rejected,
        m.status)
    if m.sample is None:  # the bit-exact mode's report: no tail
        return Kind.REPORT, body
    if len(m.sample) > m.particles:
        raise ValueError(f"a drift sample holds at most the {m.particles} live records, got "
                         f"{len(m.sample)}")
    return Kind.REPORT, body + _SAMPLE.pack(len(m.sample)) + m.sample.records


def _read_report(frame: int, payload: bytes) -> ReportMessage:
    node, rest = _read_name(payload)
    if len(rest) < _REPORT.size:
        raise ProtocolError("bad-payload", f"report body of {len(rest)} bytes, "
                                           f"expected {_REPORT.size}")
    digest, particles, emitters, step_us, checksum_us, rejected, status = \
        _REPORT.unpack_from(rest)
    if status not in Status.__members__.values():
        raise ProtocolError("bad-value", f"report status {status} is unknown")
    sample = _read_sample(rest[_REPORT.size:], particles) if len(rest) > _REPORT.size else None
    return ReportMessage(frame, node, digest.hex(), particles, emitters, step_us, checksum_us,
                         rejected, Status(status), sample)


def _read_sample(tail: bytes, particles: int) -> DriftSample:
    """A report's drift sample: a count within MAX_SAMPLE and the live count, and exactly
    that many records (their values may be anything a GPU writes: a NaN is a drift)."""
    if len(tail) < _SAMPLE.size:
        raise ProtocolError("bad-payload", f"a report's drift sample of {len(tail)} bytes has "
                                           f"no count")
    (count,) = _SAMPLE.unpack_from(tail)
    if count > min(MAX_SAMPLE, particles) \
            or len(tail) != _SAMPLE.size + count * SAMPLE_DTYPE.itemsize:
        raise ProtocolError("bad-payload", f"a drift sample of {count} records in "
                                           f"{len(tail)} bytes: expected at most "
                                           f"min({MAX_SAMPLE}, {particles} live) records of "
                                           f"{SAMPLE_DTYPE.itemsize} bytes after a 2-byte count")
    return DriftSample(tail[_SAMPLE.size:])


def _write_control(m: ControlMessage) -> tuple[Kind, bytes]:
    digest = _digest_bytes(m.digest) if m.digest else bytes(16)
    if m.digest and not any(digest):
        raise ValueError("a control message cannot name the all-zero digest (it means none)")
    if not 0 <= m.nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {m.nonce}")
    return Kind.CONTROL, bytes([m.command]) + _name_bytes(m.target, True) + _name_bytes(
        m.source, True) + _CONTROL_TAIL.pack(digest, m.nonce)


def _read_control(frame: int, payload: bytes) -> ControlMessage:
    if not payload or payload[0] not in Command.__members__.values():
        raise ProtocolError("bad-payload", "control message without a known command")
    target, rest = _read_name(payload[1:], optional=True)
    source, rest = _read_name(rest, optional=True)
    if len(rest) != _CONTROL_TAIL.size:
        raise ProtocolError("bad-payload", f"control message ends in {len(rest)} bytes, "
                                           f"expected {_CONTROL_TAIL.size}")
    digest, nonce = _CONTROL_TAIL.unpack(rest)
    return ControlMessage(frame, Command(payload[0]), target, source,
                          digest.hex() if any(digest) else "", nonce)


def _write_info_request(m: InfoRequest) -> tuple[Kind, bytes]:
    return Kind.INFO_REQUEST, _name_bytes(m.node)


def _read_info_request(frame: int, payload: bytes) -> InfoRequest:
    node, rest = _read_name(payload)
    if rest:
        raise ProtocolError("bad-payload", f"{len(rest)} stray bytes after an info request")
    return InfoRequest(frame, node)


def _write_state_request(m: StateRequest) -> tuple[Kind, bytes]:
    return Kind.STATE_REQUEST, _name_bytes(m.node) + _STATE_REQUEST.pack(
        _digest_bytes(m.digest))


def _read_state_request(frame: int, payload: bytes) -> StateRequest:
    node, rest = _read_name(payload)
    if len(rest) != _STATE_REQUEST.size:
        raise ProtocolError("bad-payload", f"state request body of {len(rest)} bytes, "
                                           f"expected {_STATE_REQUEST.size}")
    (digest,) = _STATE_REQUEST.unpack(rest)
    return StateRequest(frame, node, digest.hex())


def _write_block_request(m: BlockRequest) -> tuple[Kind, bytes]:
    indices = np.asarray(m.indices, dtype=np.int64)
    if m.part not in _PARTS[m.query] or len(indices) > MAX_BLOCK_INDICES \
            or (indices.size and (indices[0] < 0 or indices[-1] >= 2**32
                                  or np.any(np.diff(indices) <= 0))) \
            or (m.query is not BlockQuery.TREE and not indices.size):
        raise ValueError(f"a {m.query.name} block request names part {m.part} (allowed: "
                         f"{_PARTS[m.query]}) and 1 to {MAX_BLOCK_INDICES} ascending indices "
                         f"(a TREE request may name none), got {len(indices)}")
    return Kind.BLOCK_REQUEST, _name_bytes(m.node) + _BLOCK_REQUEST.pack(
        _digest_bytes(m.digest), m.query, m.part, len(indices)) + indices.astype("<u4").tobytes()


def _read_block_request(frame: int, payload: bytes) -> BlockRequest:
    node, rest = _read_name(payload)
    if len(rest) < _BLOCK_REQUEST.size:
        raise ProtocolError("bad-payload", f"block request body of {len(rest)} bytes is too "
                                           f"short")
    digest, query, part, count = _BLOCK_REQUEST.unpack_from(rest)
    if query not in BlockQuery.__members__.values() or part not in _PARTS[BlockQuery(query)]:
        raise ProtocolError("bad-value", f"block query {query} of part {part} is unknown")
    if count > MAX_BLOCK_INDICES or len(rest) != _BLOCK_REQUEST.size + 4 * count:
        raise ProtocolError("bad-payload", f"a block request of {count} indices in "
                                           f"{len(rest)} bytes (at most {MAX_BLOCK_INDICES})")
    indices = np.frombuffer(rest, "<u4", count, _BLOCK_REQUEST.size).astype(np.int64)
    if np.any(np.diff(indices) <= 0) or (query != BlockQuery.TREE and not count):
        raise ProtocolError("bad-value", "block request indices must be ascending, and only "
                                         "a TREE request may name none")
    return BlockRequest(frame, node, digest.hex(), BlockQuery(query), part,
                        tuple(indices.tolist()))


def _write_block_reply(m: BlockReply) -> tuple[Kind, bytes]:
    if m.part not in _PARTS[m.query] or len(m.data) > MAX_BLOCK_BYTES \
            or len(m.data) % m.unit or len(m.history) > HISTORY_FRAMES \
            or not (0 <= m.particles <= MAX_PARTICLES and 0 <= m.emitters <= MAX_EMITTERS):
        raise ValueError(f"a block reply holds whole items or records of at most "
                         f"{MAX_BLOCK_BYTES} bytes, {HISTORY_FRAMES} history frames and counts "
                         f"within the limits, got {len(m.data)} bytes, {len(m.history)} "
                         f"frames, {m.particles} and {m.emitters}")
    history = b"".join(_HISTORY_FRAME.pack(h.frame, h.particles, h.emitters)
                       for h in m.history)
    return Kind.BLOCK_REPLY, _name_bytes(m.node) + _BLOCK_REPLY.pack(
        m.query, m.part, m.seed, m.particles, m.emitters, len(m.history)) + history + m.data


def _read_block_reply(frame: int, payload: bytes) -> BlockReply:
    node, rest = _read_name(payload)
    if len(rest) < _BLOCK_REPLY.size:
        raise ProtocolError("bad-payload", f"block reply body of {len(rest)} bytes is too "
                                           f"short")
    query, part, seed, particles, emitters, frames = _BLOCK_REPLY.unpack_from(rest)
    if query not in BlockQuery.__members__.values() or part not in _PARTS[BlockQuery(query)]:
        raise ProtocolError("bad-value", f"block query {query} of part {part} is unknown")
    if particles > MAX_PARTICLES or emitters > MAX_EMITTERS or frames > HISTORY_FRAMES:
        raise ProtocolError("bad-value", f"a block reply of {particles} particles, {emitters} "
                                         f"emitters and {frames} history frames is beyond the "
                                         f"limits")
    start = _BLOCK_REPLY.size + frames * _HISTORY_FRAME.size
    history = tuple(HistoryFrame(*_HISTORY_FRAME.unpack_from(rest, _BLOCK_REPLY.size + i *
                                                             _HISTORY_FRAME.size))
                    for i in range(frames)) if len(rest) >= start else ()
    reply = BlockReply(frame, node, BlockQuery(query), part, seed, particles, emitters,
                       rest[start:], history)
    if len(rest) < start or len(reply.data) > MAX_BLOCK_BYTES or len(reply.data) % reply.unit:
        raise ProtocolError("bad-payload", f"a block reply's data of {len(rest) - start} "
                                           f"bytes is not whole {reply.unit}-byte items "
                                           f"within {MAX_BLOCK_BYTES} bytes")
    return reply


def _write_snapshot(m: SnapshotHeader) -> tuple[Kind, bytes]:
    emitters = np.ascontiguousarray(m.emitters, dtype=EMITTER_DTYPE)
    if not (0 <= m.particles <= MAX_PARTICLES and len(emitters) <= MAX_EMITTERS
            and 1 <= m.chunk_particles <= MAX_CHUNK_PARTICLES):
        raise ValueError(f"a snapshot holds at most {MAX_PARTICLES} particles and "
                         f"{MAX_EMITTERS} emitters in chunks of 1 to "
                         f"{MAX_CHUNK_PARTICLES} particles, got {m.particles}, "
                         f"{len(emitters)} and {m.chunk_particles}")
    return Kind.SNAPSHOT, _SNAPSHOT.pack(m.seed, m.particles, len(emitters), m.chunk_particles,
                                         _digest_bytes(m.digest)) + emitters.tobytes()


def _read_snapshot(frame: int, payload: bytes) -> SnapshotHeader:
    if len(payload) < _SNAPSHOT.size:
        raise ProtocolError("bad-payload", f"snapshot header of {len(payload)} bytes is too "
                                           f"short")
    seed, particles, emitters, chunk, digest = _SNAPSHOT.unpack_from(payload)
    if particles > MAX_PARTICLES or emitters > MAX_EMITTERS \
            or not 1 <= chunk <= MAX_CHUNK_PARTICLES \
            or len(payload) != _SNAPSHOT.size + emitters * EMITTER_DTYPE.itemsize:
        raise ProtocolError("bad-payload", f"snapshot of {particles} particles in chunks of "
                                           f"{chunk} and {emitters} emitters does not fit "
                                           f"{len(payload)} bytes or the limits")
    e = np.frombuffer(payload, EMITTER_DTYPE, emitters, _SNAPSHOT.size)
    return SnapshotHeader(frame, seed, particles, chunk, digest.hex(), e.copy())


def _write_chunk(m: SnapshotChunk) -> tuple[Kind, bytes]:
    records, rest = divmod(len(m.data), PARTICLE_BYTES)
    if rest or not 1 <= records <= MAX_CHUNK_PARTICLES or not 0 <= m.index < MAX_PARTICLES:
        raise ValueError(f"a chunk is 1 to {MAX_CHUNK_PARTICLES} whole {PARTICLE_BYTES}-byte "
                         f"records with an index below {MAX_PARTICLES}, got "
                         f"{len(m.data)} bytes at index {m.index}")
    return Kind.CHUNK, _CHUNK.pack(m.index) + bytes(m.data)


def _read_chunk(frame: int, payload: bytes) -> SnapshotChunk:
    records, rest = divmod(len(payload) - _CHUNK.size, PARTICLE_BYTES)
    if len(payload) < _CHUNK.size or rest or not 1 <= records <= MAX_CHUNK_PARTICLES:
        raise ProtocolError("bad-payload", f"snapshot chunk of {len(payload)} bytes is not an "
                                           f"index and 1 to {MAX_CHUNK_PARTICLES} whole "
                                           f"{PARTICLE_BYTES}-byte records")
    (index,) = _CHUNK.unpack_from(payload)
    if index >= MAX_PARTICLES:
        raise ProtocolError("bad-value", f"chunk index {index} is beyond any snapshot "
                                         f"(at most {MAX_PARTICLES} particles)")
    return SnapshotChunk(frame, index, payload[_CHUNK.size:])


def _write_tracking(m: TrackingMessage) -> tuple[Kind, bytes]:
    h, w = m.head, m.wand
    values = np.array([*h.position, *h.orientation, *w.position, *w.orientation, *w.axes])
    if not np.all(np.isfinite(values)) or np.any(np.abs(values) > np.finfo(np.float32).max):
        raise ValueError(f"tracking values must be finite float32 values, got {h} and {w}")
    return Kind.TRACKING, _TRACKING.pack(*h.position, *h.orientation, *w.position,
                                         *w.orientation, w.buttons, *w.axes)


def _read_tracking(frame: int, payload: bytes) -> TrackingMessage:
    if len(payload) != _TRACKING.size:
        raise ProtocolError("bad-payload", f"tracking payload of {len(payload)} bytes, "
                                           f"expected {_TRACKING.size}")
    v = _TRACKING.unpack(payload)
    if not all(math.isfinite(x) for x in (*v[:14], *v[15:])):
        raise ProtocolError("bad-value", "head and wand values must be finite")
    return TrackingMessage(frame, HeadState(v[0:3], v[3:7]), WandState(v[7:10], v[10:14], v[14],
                                                                         v[15:19]))


def _write_info(m: InfoMessage) -> tuple[Kind, bytes]:
    if not 0 <= m.device <= 0xFFFF:
        raise ValueError(f"EGL device index must be in [0, 65535], got {m.device}")
    texts = b"".join(_text_bytes(what, getattr(m, what))
                     for what in ("renderer", "vendor", "version"))
    flags = (INFO_SOFTWARE if m.software else 0) | (INFO_SWAP_LOCKED if m.swap_locked else 0)
    if not 0 <= m.nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {m.nonce}")
    return Kind.INFO, _name_bytes(m.node) + _INFO.pack(m.device, flags, m.nonce) + texts


def _read_info(frame: int, payload: bytes) -> InfoMessage:
    node, rest = _read_name(payload)
    if len(rest) < _INFO.size:
        raise ProtocolError("bad-payload", f"info body of {len(rest)} bytes is too short")
    device, flags, nonce = _INFO.unpack_from(rest)
    if flags & ~(INFO_SOFTWARE | INFO_SWAP_LOCKED):
        raise ProtocolError("bad-value", f"info flags {flags:#x}: only "
                                         f"{INFO_SOFTWARE | INFO_SWAP_LOCKED:#x} are defined")
    rest = rest[_INFO.size:]
    texts = []
    for _ in range(3):
        text, rest = _read_text(rest)
        texts.append(text)
    if rest:
        raise ProtocolError("bad-payload", f"{len(rest)} stray bytes after an info message")
    return InfoMessage(frame, node, device, bool(flags & INFO_SOFTWARE), *texts,
                       swap_locked=bool(flags & INFO_SWAP_LOCKED), nonce=nonce)


def _write_display(m: DisplayMessage) -> tuple[Kind, bytes]:
    if not 0 <= m.time_ns < 2**64:
        raise ValueError(f"time_ns must be in [0, 2**64), got {m.time_ns}")
    return Kind.DISPLAY, _name_bytes(m.node) + _DISPLAY.pack(Phase(m.phase), m.time_ns)


def _read_display(frame: int, payload: bytes) -> DisplayMessage:
    node, rest = _read_name(payload)
    if len(rest) != _DISPLAY.size:
        raise ProtocolError("bad-payload", f"display body of {len(rest)} bytes, expected "
                                           f"{_DISPLAY.size}")
    phase, time_ns = _DISPLAY.unpack(rest)
    if phase not in Phase.__members__.values():
        raise ProtocolError("bad-value", f"display phase {phase} is unknown")
    return DisplayMessage(frame, node, Phase(phase), time_ns)


def _text_bytes(what: str, text: str) -> bytes:
    if len(text) > MAX_TEXT or any(not " " <= c <= "~" for c in text):
        raise ValueError(f"{what} must be printable ASCII of at most {MAX_TEXT} characters, "
                         f"got {text!r}")
    return bytes([len(text)]) + text.encode("ascii")


def _read_text(data: bytes) -> tuple[str, bytes]:
    if not data or len(data) < 1 + data[0]:
        raise ProtocolError("bad-payload", "a string runs past the end of the message")
    raw, rest = data[1:1 + data[0]], data[1 + data[0]:]
    if any(not 0x20 <= b <= 0x7E for b in raw):
        raise ProtocolError("bad-value", f"string {raw!r} is not printable ASCII")
    return raw.decode("ascii"), rest


def _name_bytes(name: str, optional: bool = False) -> bytes:
    if not (optional and name == ""):
        check_name("node name", name)
    return bytes([len(name)]) + name.encode()


def _read_name(data: bytes, optional: bool = False) -> tuple[str, bytes]:
    if not data or len(data) < 1 + data[0]:
        raise ProtocolError("bad-payload", "a node name runs past the end of the message")
    raw, rest = data[1:1 + data[0]], data[1 + data[0]:]
    try:
        name = raw.decode("ascii")
        if not (optional and name == ""):
            check_name("node name", name)
    except (UnicodeDecodeError, ValueError) as e:
        raise ProtocolError("bad-payload", f"node name {raw!r} is not allowed") from e
    return name, rest


_PAYLOAD_WRITERS = {FrameMessage: _write_frame, ReportMessage: _write_report,
                    ControlMessage: _write_control, SnapshotHeader: _write_snapshot,
                    SnapshotChunk: _write_chunk, TrackingMessage: _write_tracking,
                    InfoMessage: _write_info, DisplayMessage: _write_display,
                    InfoRequest: _write_info_request, StateRequest: _write_state_request,
                    BlockRequest: _write_block_request, BlockReply: _write_block_reply}
_PAYLOAD_READERS = {Kind.FRAME: _read_frame, Kind.REPORT: _read_report,
                    Kind.CONTROL: _read_control, Kind.SNAPSHOT: _read_snapshot,
                    Kind.CHUNK: _read_chunk, Kind.TRACKING: _read_tracking,
                    Kind.INFO: _read_info, Kind.DISPLAY: _read_display,
                    Kind.INFO_REQUEST: _read_info_request,
                    Kind.STATE_REQUEST: _read_state_request,
                    Kind.BLOCK_REQUEST: _read_block_request, Kind.BLOCK_REPLY: _read_block_reply}
