"""The wire format on its own (no network): round trips, every rejection, and fuzzing.

Crafted inputs are built here from the documented layout (a 36-byte header, the payload,
for the master's kinds the master's Ed25519 signature of both, and an HMAC-SHA256 of all
that), not with `encode`, so the tests pin the format rather than echo it.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import re
import struct
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from cluster_helpers import (
    U64,
    Mutation,
    control_messages,
    credential_sets,
    digests,
    dts,
    frame_messages,
    frame_numbers,
    info_messages,
    messages,
    mutate,
    mutations,
    names,
    optional_names,
)
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey
from hypothesis import assume, example, given
from hypothesis import strategies as st

from cavesim.core.counters import COUNTERS, MAX_ENTRIES, MAX_ID, MAX_VALUES
from cavesim.core.drift import MAX_SAMPLE, SAMPLE_DTYPE, DriftSample
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import NO_COST, PHASES
from cavesim.core.limits import MAX_EMITTERS, MAX_PARTICLE_CLASSES, MAX_PARTICLES
from cavesim.core.scene import Engine
from cavesim.core.wire import envelope
from cavesim.core.wire.credentials import Credentials, generate, of_master
from cavesim.core.wire.envelope import VERSION, Kind, decode, decode_envelope, encode, session_id
from cavesim.core.wire.payloads.from_master import (
    MAX_PARAMS,
    Command,
    ControlMessage,
    FrameMessage,
    InfoRequest,
)
from cavesim.core.wire.payloads.from_nodes import (
    MAX_TEXT,
    DisplayMessage,
    InfoMessage,
    Phase,
    ReportMessage,
    Status,
)
from cavesim.core.wire.payloads.poses import (
    HeadState,
    SessionControls,
    TrackingMessage,
    WandState,
)
from cavesim.core.wire.payloads.state_transfer import (
    MAX_BLOCK_BYTES,
    MAX_BLOCK_INDICES,
    MAX_CHUNK_PARTICLES,
    BlockQuery,
    BlockReply,
    BlockRequest,
    HistoryFrame,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
)
from cavesim.gpu.engine import EMITTER_DTYPE, FrameInput

SESSION = "wiretest"
MASTER = generate()
MEMBER = MASTER.for_members()  # what nodes and trackers hold: no master signing key
OTHER = generate()  # another session's: another secret and another master key pair

# magic, version, kind, flags, reserved, session id, run id, frame, payload length
HEADER = struct.Struct("<4sBBBBQQQI")
RUN_ID_AT, FRAME_AT, PAYLOAD_AT = 16, 24, 36  # where the run id, frame and payload start
SIGNED, MASTER_SIGNED, MEMBER_SIGNED = 0x01, 0x02, 0x04  # header flags
HMAC_BYTES, MASTER_SIGNATURE_BYTES = 32, 64
MASTER_KINDS = {Kind.FRAME, Kind.CONTROL, Kind.INFO_REQUEST}  # only the master sends these
MASTER_MESSAGES = (FrameMessage, ControlMessage, InfoRequest)  # ... as these messages

FRAME_BODY = struct.Struct("<I9f3f4f3f4fI4fH")  # dt bits, matrix, head, wand, param count
# head, wand, buttons, axes, sent_ns, flags (posed 1, controls 2, paused 4, quit 8), resets
TRACKING_BODY = struct.Struct("<3f4f3f4fI4fQBI")
IDENTITY = np.eye(3, dtype=np.float32)
MATRIX = np.array([[3, -2, 17], [5, 1, 250], [0, 0, 1]], dtype=np.float32)
DIGEST = "00112233445566778899aabbccddeeff"
HEAD = HeadState((0.0, 0.0, 1.75))  # float32-exact


def with_hmac(data: bytes, secret: bytes = MASTER.secret) -> bytes:
    """`data` with its HMAC appended: what anyone holding the session's secret can make."""
    return data + hmac.new(secret, data, hashlib.sha256).digest()


def craft(kind: int, payload: bytes, *, frame: int = 1, run_id: int = 0,
          session: str = SESSION, flags: int | None = None, reserved: int = 0,
          secret: bytes | None = None, master_key: bytes | None = None,
          magic: bytes = b"CVSM", version: int = VERSION, length: int | None = None) -> bytes:
    """A message built by hand from the layout: with `master_key` (an Ed25519 private key)
    its signature of header and payload follows, with `secret` an HMAC of all that; the
    flags say so unless given."""
    if flags is None:
        flags = (SIGNED if secret else 0) | (MASTER_SIGNED if master_key else 0)
    data = HEADER.pack(magic, version, kind, flags, reserved, session_id(session), run_id,
                       frame, len(payload) if length is None else length) + payload
    if master_key:
        data += Ed25519PrivateKey.from_private_bytes(master_key).sign(data)
    return with_hmac(data, secret) if secret else data


def by_master(kind: int, payload: bytes, **fields) -> bytes:
    """Signed as the master signs: its Ed25519 signature, then the session's HMAC."""
    return craft(kind, payload, secret=MASTER.secret, master_key=MASTER.master_private,
                 **fields)


def by_member(kind: int, payload: bytes, **fields) -> bytes:
    """Signed as a node or a tracker can sign: the session's HMAC only."""
    return craft(kind, payload, secret=MASTER.secret, **fields)


def strip_master_signature(data: bytes) -> bytes:
    """A master-signed message as a member could re-sign it: the master's signature cut
    out, its flag cleared, a fresh HMAC."""
    body = data[:-(MASTER_SIGNATURE_BYTES + HMAC_BYTES)]
    return with_hmac(body[:6] + bytes([SIGNED]) + body[7:])


def flipped(data: bytes, index: int, bit: int = 0) -> bytes:
    changed = bytearray(data)
    changed[index] ^= 1 << bit
    return bytes(changed)


def frame_body(dt_bits: int = 0x3C888889, matrix=IDENTITY, position=(0.0, 0.0, 0.0),
               orientation=(0.0, 0.0, 0.0, 1.0), buttons: int = 0, axes=(0.0,) * 4,
               params=(), count: int | None = None, head_position=(0.0, 0.0, 1.7),
               head_orientation=(0.0, 0.0, 0.0, 1.0), events: int | None = 0) -> bytes:
    """A frame payload; `count` may disagree with the parameters that follow; `events`
    None: no events byte (the layout before wire version 11)."""
    count = len(params) if count is None else count
    return FRAME_BODY.pack(dt_bits, *np.asarray(matrix, np.float32).ravel().tolist(),
                           *head_position, *head_orientation, *position, *orientation,
                           buttons, *axes, count) + \
        struct.pack(f"<{len(params)}f", *params) + (b"" if events is None else bytes([events]))


def name(text: bytes) -> bytes:
    return bytes([len(text)]) + text


def control_body(command: int = Command.STOP, target: bytes = b"", source: bytes = b"",
                 digest: bytes = bytes(16), nonce: int = 0, engine: int = 0,
                 confirmer: bytes = b"") -> bytes:
    """A control payload: command, target, source, confirmer, the digest (zeros: none), the
    nonce, the engine (0: none, 1: gs_tf, 2: compute)."""
    return bytes([command]) + name(target) + name(source) + name(confirmer) + digest + \
        struct.pack("<QB", nonce, engine)


STOP_BODY = control_body()


def snapshot_body(particles: int = 3, emitters: int = 0, chunk: int = 2) -> bytes:
    """A snapshot header's payload; `emitters` is only the count (no records follow)."""
    return struct.pack("<QIII16s", 9, particles, emitters, chunk, bytes.fromhex(DIGEST))


COST = tuple(range(3, 3 + len(PHASES)))  # a report's phase times, microseconds


def report_body(node: bytes = b"front", status: int = 0, extra: bytes = b"",
                particles: int = 1, counters: bytes = b"\x00") -> bytes:
    """A report: name, the fixed core, the counter tail (by default: none counted)."""
    return name(node) + struct.pack(f"<16sII{len(PHASES)}IIB", bytes.fromhex(DIGEST),
                                    particles, 2, *COST, 5, status) + counters + extra


def counter_tail(*entries: tuple[int, tuple[int, ...]], count: int | None = None) -> bytes:
    """A report's counter tail: the number of entries (default: as many as given), then per
    entry its id, its number of values and the values."""
    return bytes([len(entries) if count is None else count]) + b"".join(
        struct.pack(f"<HB{len(values)}I", id_, len(values), *values) for id_, values in entries)


def sample_tail(count: int, records: int | None = None) -> bytes:
    """A report's drift sample: the count, then `records` (default: count) zero records."""
    return struct.pack("<H", count) + bytes(SAMPLE_DTYPE.itemsize * (
        count if records is None else records))


SAMPLE = DriftSample.of(np.array([[1.5, -2.0, 0.25], [math.nan, math.inf, -0.0]]),
                        np.array([[0.0, 1e-45, -3e38], [1.0, 2.0, 3.0]]))


def info_body(node: bytes = b"front", device: int = 0, flags: int = 1, nonce: int = 0,
              texts=(b"llvmpipe", b"Mesa", b"4.5 Mesa"), extra: bytes = b"",
              scene: bytes = bytes(16)) -> bytes:
    return name(node) + struct.pack("<HBQ16s", device, flags, nonce, scene) + \
        b"".join(map(name, texts)) + extra


REQUEST_NONCE = 0x0123456789ABCDEF  # a request's nonce, fixed so that its bytes can be crafted


def asked(asker: bytes = b"", nonce: int = REQUEST_NONCE) -> bytes:
    """A request's tail: its nonce, then its asker's name (empty: none)."""
    return struct.pack("<Q", nonce) + name(asker)


def state_request_body(node: bytes = b"left", digest: bytes = bytes.fromhex(DIGEST)) -> bytes:
    return name(node) + digest + asked()


BLOCK_REQUEST_HEAD = struct.Struct("<16sBBI")  # digest, query, part, index count
BLOCK_REPLY_HEAD = struct.Struct("<BBQIIB")  # query, part, seed, particles, emitters, frames


def block_request_body(query: int = BlockQuery.RECORDS, part: int = 0, indices=(3, 9),
                       count: int | None = None) -> bytes:
    return name(b"left") + BLOCK_REQUEST_HEAD.pack(
        bytes.fromhex(DIGEST), query, part, len(indices) if count is None else count) \
        + np.asarray(indices, "<u4").tobytes() + asked()


def block_reply_body(query: int = BlockQuery.TREE, part: int = 1, particles: int = 10,
                     emitters: int = 0, frames: int = 0, data: bytes = bytes(16)) -> bytes:
    return name(b"left") + BLOCK_REPLY_HEAD.pack(query, part, 7, particles, emitters, frames) \
        + bytes(16 * frames) + data


def f32_bits(value: float) -> int:
    return int(np.float32(value).view(np.uint32))


def bits(values) -> tuple[int, ...]:
    return tuple(f32_bits(v) for v in values)


def comparable(m) -> tuple:
    """The fields of a message with floats as float32 bits (so -0.0 != 0.0)."""
    if isinstance(m, FrameMessage):
        w = m.wand
        return (type(m), m.frame, f32_bits(m.inputs.dt), m.inputs.random_transform.tobytes(),
                bits(w.position), bits(w.orientation), w.buttons, bits(w.axes), bits(m.params),
                bits(m.head.position), bits(m.head.orientation))
    if isinstance(m, SnapshotHeader):
        return (type(m), m.frame, m.seed, m.particles, m.chunk_particles, m.digest,
                m.emitters.dtype, m.emitters.tobytes())
    return (type(m), m)


def sender(message, credentials: Credentials | None = MASTER) -> Credentials | None:
    """Who sends `message` in a session with `credentials`: the master its own kinds, a
    member (no signing key) every other kind; nobody signs in a session without them."""
    if credentials is None or isinstance(message, MASTER_MESSAGES):
        return credentials
    return credentials.for_members()


def signature_bytes(message) -> int:
    """What a signed `message` carries after its payload."""
    return HMAC_BYTES + (MASTER_SIGNATURE_BYTES if isinstance(message, MASTER_MESSAGES) else 0)


def members_of(credentials: Credentials | None) -> Credentials | None:
    return None if credentials is None else credentials.for_members()


def reason_of(data: bytes, session: str = SESSION,
              credentials: Credentials | None = None) -> str:
    with pytest.raises(ProtocolError) as error:
        decode(data, session, credentials)
    return error.value.reason


# -- strategies beyond cluster_helpers' (the kinds and fields version 4 added) -------------

master_keys = st.binary(min_size=32, max_size=32)  # Ed25519 private keys
run_ids = st.integers(0, U64)
nonces = st.integers(0, U64)
# A control message's all-zero digest is how the wire writes "no digest": it reads back as
# "", so the drawn digests are never all zeros.
control_digests = st.just("") | digests.filter(lambda digest: digest != "0" * 32)
controls_with_digest_and_nonce = st.builds(replace, control_messages, digest=control_digests,
                                           nonce=nonces, confirmer=optional_names)
infos_with_nonce = st.builds(replace, info_messages, nonce=nonces)
info_requests = st.builds(InfoRequest, frame_numbers, names)
state_requests = st.builds(StateRequest, frame_numbers, names, digests)
block_indices = st.lists(st.integers(0, 2**32 - 1), min_size=1, max_size=40,
                         unique=True).map(lambda drawn: tuple(sorted(drawn)))
block_requests = st.one_of(
    st.builds(BlockRequest, frame_numbers, names, digests, st.just(BlockQuery.TREE),
              st.integers(0, 2), st.just(()) | block_indices),
    st.builds(BlockRequest, frame_numbers, names, digests, st.just(BlockQuery.HISTORY),
              st.just(1), block_indices),
    st.builds(BlockRequest, frame_numbers, names, digests, st.just(BlockQuery.RECORDS),
              st.integers(0, 1), block_indices),
    st.builds(BlockRequest, frame_numbers, names, digests, st.just(BlockQuery.DIGEST),
              st.integers(0, 1), st.just(()) | block_indices))
history_frames = st.lists(st.builds(HistoryFrame, st.integers(0, U64),
                                    st.integers(0, MAX_PARTICLES), st.integers(0, MAX_EMITTERS)),
                          max_size=3).map(tuple)
block_replies = st.one_of(
    st.builds(lambda f, n, part, units, c: BlockReply(f, n, BlockQuery.TREE, part, 5, c, 1,
                                                      bytes((8, 16, 16)[part] * units)),
              frame_numbers, names, st.integers(0, 2), st.integers(0, 20),
              st.integers(0, MAX_PARTICLES)),
    st.builds(lambda f, n, history, units: BlockReply(f, n, BlockQuery.HISTORY, 1, 0, 3, 2,
                                                      bytes(16 * units * len(history)),
                                                      history),
              frame_numbers, names, history_frames, st.integers(0, 10)),
    st.builds(lambda f, n, part, units: BlockReply(f, n, BlockQuery.RECORDS, part, U64, 9, 4,
                                                   bytes((40, 16)[part] * units)),
              frame_numbers, names, st.integers(0, 1), st.integers(1, 20)))
all_messages = st.one_of(messages(), controls_with_digest_and_nonce, infos_with_nonce,
                         info_requests, state_requests, block_requests, block_replies)
master_messages = st.one_of(frame_messages, controls_with_digest_and_nonce, info_requests)


# -- round trips ---------------------------------------------------------------------------

EDGE_MESSAGES = {
    "frame": FrameMessage(1, FrameInput(1 / 60, MATRIX)),
    "frame-max-params": FrameMessage(U64, FrameInput(0.0, IDENTITY), WandState(
        (1.5, -2.0, 3e38), (0.0, 0.0, -0.0, 1.0), 2**32 - 1, (-1.0, 1.0, 0.5, 1e-45)),
        tuple(float(i) - 0.5 for i in range(MAX_PARAMS)),
        HeadState((-3e38, 0.0, 1e-45), (-0.0, 0.0, 0.0, -1.0))),
    "frame-zero": FrameMessage(0, FrameInput(-0.0, IDENTITY)),
    "frame-reset": FrameMessage(3, FrameInput(1 / 60, MATRIX), reset=True),
    "report": ReportMessage(7, "front", DIGEST, 1490, 1, COST, 3, Status.STEPPED),
    "report-edges": ReportMessage(U64, "x" * 32, "f" * 32, 2**32 - 1, 0,
                                  (0, 2**32 - 1) * (len(PHASES) // 2) + (0,) * (len(PHASES) % 2),
                                  2**32 - 1, Status.REPEATED),
    "report-resynced": ReportMessage(2, "wall_7-b", "0" * 32, 0, 0, NO_COST, 0,
                                     Status.RESYNCED),
    "report-joined": ReportMessage(0, "left", DIGEST, 0, 0, NO_COST, 0, Status.JOINED),
    "report-behind": ReportMessage(U64, "front", "f" * 32, 1, 1, (1,) * len(PHASES), 1,
                                   Status.BEHIND),
    "report-sample": ReportMessage(8, "left", DIGEST, 2, 1, COST, 0, Status.STEPPED, SAMPLE),
    "report-sample-empty": ReportMessage(1, "left", DIGEST, 0, 0, NO_COST, 0,
                                         sample=DriftSample(b"")),
    "report-counters": ReportMessage(5, "left", DIGEST, 7, 1, COST, 0, Status.STEPPED,
                                     counters=((1, (0,) * MAX_PARTICLE_CLASSES),
                                               (2, (2**32 - 1,)), (3, (1,)), (4, (0,)),
                                               (5, (9,)), (6, (64,)),
                                               (MAX_ID, (0,) * MAX_VALUES), (77, ()))),
    "report-counters-most-and-sample": ReportMessage(
        6, "left", DIGEST, 2, 1, COST, 0, Status.STEPPED, SAMPLE,
        tuple((1000 + i, tuple(range(MAX_VALUES))) for i in range(MAX_ENTRIES))),
    "report-sample-largest": ReportMessage(9, "left", DIGEST, 2**32 - 1, 0, NO_COST, 0,
                                           Status.RESYNCED, DriftSample(
                                               bytes(range(256)) * 96)),
    "stop": ControlMessage(400, Command.STOP),
    "swap": ControlMessage(0, Command.SWAP),
    "resync": ControlMessage(U64, Command.RESYNC, "left", "front", DIGEST),
    "resync-long-names": ControlMessage(3, Command.RESYNC, "a" * 32, "B-_9" * 8, "f" * 32),
    "resync-confirmed": ControlMessage(4, Command.RESYNC, "left", "front", DIGEST,
                                       confirmer="x" * 32),
    "welcome": ControlMessage(0, Command.WELCOME, "front", nonce=U64),
    "welcome-nonce-1": ControlMessage(1, Command.WELCOME, "x" * 32, nonce=1),
    "welcome-engine": ControlMessage(1, Command.WELCOME, "front", nonce=2,
                                     engine=Engine.COMPUTE),
    "snapshot-empty": SnapshotHeader(5, 1, 0, 1, DIGEST, np.zeros(0, EMITTER_DTYPE)),
    "snapshot": SnapshotHeader(U64, U64, 3, 2, DIGEST,
                               np.arange(2 * 4, dtype="<u4").view(EMITTER_DTYPE)),
    "snapshot-largest": SnapshotHeader(1, 0, MAX_PARTICLES, MAX_CHUNK_PARTICLES,
                                       "f" * 32, np.zeros(MAX_EMITTERS, EMITTER_DTYPE)),
    "chunk": SnapshotChunk(U64, 7, bytes(range(40)) * 2),
    "chunk-last-index": SnapshotChunk(0, MAX_PARTICLES - 1, bytes(40)),
    "tracking": TrackingMessage(12, HeadState((0.25, -0.5, 1.75), (0.0, 0.0, 0.5, 0.75)),
                                WandState((1.0, 2.0, 1.25), (0.5, 0.0, 0.0, 0.5), 5,
                                          (0.25, -1.0, 0.0, 0.5))),
    "tracking-controls": TrackingMessage(3, HEAD, WandState(), 5, posed=False,
                                         controls=SessionControls(True, 2**32 - 1, True)),
    "tracking-controls-posed": TrackingMessage(4, HEAD, WandState(), U64,
                                               controls=SessionControls(resets=1)),
    "info": InfoMessage(3, "front", 0, True, "llvmpipe (LLVM 15.0.6, 256 bits)", "Mesa/X.org",
                        "4.5 (Core Profile) Mesa 22.3.6"),
    "info-edges": InfoMessage(U64, "x" * 32, 2**16 - 1, False, "~" * MAX_TEXT, "", " ",
                              swap_locked=True, nonce=U64),
    "display-drawn": DisplayMessage(0, "left", Phase.DRAWN, 0),
    "display-swapped": DisplayMessage(U64, "x" * 32, Phase.SWAPPED, U64),
    "info-request": InfoRequest(0, "front"),
    "info-request-edges": InfoRequest(U64, "B-_9" * 8),
    "state-request": StateRequest(7, "left", DIGEST),
    "state-request-edges": StateRequest(U64, "x" * 32, "0" * 32),
    "block-request-whole-level": BlockRequest(9, "left", DIGEST, BlockQuery.TREE, 2),
    "block-request-most-indices": BlockRequest(U64, "x" * 32, "f" * 32, BlockQuery.RECORDS, 1,
                                               tuple(range(2**32 - MAX_BLOCK_INDICES, 2**32))),
    "block-request-history": BlockRequest(0, "front", "0" * 32, BlockQuery.HISTORY, 1, (0,)),
    "block-request-digest-whole": BlockRequest(5, "left", DIGEST, BlockQuery.DIGEST, 0),
    "block-request-digest-named": BlockRequest(5, "left", DIGEST, BlockQuery.DIGEST, 1,
                                               (0, 2**32 - 1)),
    "block-reply-digest": BlockReply(5, "left", BlockQuery.DIGEST, 0, U64, MAX_PARTICLES, 3,
                                     bytes(range(32))),
    "block-reply-sums": BlockReply(3, "left", BlockQuery.TREE, 0, U64, MAX_PARTICLES,
                                   MAX_EMITTERS, bytes(range(16))),
    "block-reply-history": BlockReply(U64, "x" * 32, BlockQuery.HISTORY, 1, 0, 0, 0,
                                      bytes(range(64)) * 2,
                                      (HistoryFrame(U64 - 1, 4, 1), HistoryFrame(U64, 5, 1))),
    "block-reply-largest": BlockReply(1, "front", BlockQuery.RECORDS, 0, 1, 1, 0,
                                      bytes(MAX_BLOCK_BYTES // 40 * 40)),
    "block-reply-empty": BlockReply(1, "front", BlockQuery.TREE, 2, 0, 0, 0, b""),
}
MEMBER_EDGE_MESSAGES = {key: message for key, message in EDGE_MESSAGES.items()
                        if not isinstance(message, MASTER_MESSAGES)}


@pytest.mark.parametrize("signed", [False, True], ids=["unsigned", "signed"])
@pytest.mark.parametrize("message", EDGE_MESSAGES.values(), ids=EDGE_MESSAGES.keys())
def test_every_kind_round_trips_with_edge_values(message, signed):
    credentials = sender(message) if signed else None
    data = encode(message, SESSION, credentials)
    length = HEADER.unpack_from(data)[-1]
    assert len(data) == HEADER.size + length + (signature_bytes(message) if signed else 0)
    for receiver in [MEMBER, MASTER] if signed else [None]:
        envelope = decode_envelope(data, SESSION, receiver)
        assert comparable(envelope.message) == comparable(message)
        assert envelope.run_id == 0
        assert envelope.from_master == (signed and isinstance(message, MASTER_MESSAGES))
    assert encode(envelope.message, SESSION, credentials) == data


@pytest.mark.parametrize("run_id", [0, 1, U64])
@pytest.mark.parametrize("key", ["frame", "report", "info-request", "state-request"])
def test_the_run_id_round_trips_in_the_envelope(key, run_id):
    message = EDGE_MESSAGES[key]
    for credentials, receiver in [(None, None), (sender(message), MEMBER)]:
        data = encode(message, SESSION, credentials, run_id)
        assert HEADER.unpack_from(data)[6] == run_id
        envelope = decode_envelope(data, SESSION, receiver)
        assert envelope.run_id == run_id
        assert comparable(envelope.message) == comparable(message)


@given(message=all_messages, credentials=st.none() | credential_sets, run_id=run_ids)
def test_any_message_round_trips(message, credentials, run_id):
    data = encode(message, SESSION, sender(message, credentials), run_id)
    envelope = decode_envelope(data, SESSION, members_of(credentials))
    assert comparable(envelope.message) == comparable(message)
    assert envelope.run_id == run_id
    assert envelope.from_master == (credentials is not None
                                    and isinstance(message, MASTER_MESSAGES))


@given(dt=dts)
@example(dt=0.0).via("zero")
@example(dt=-0.0).via("negative zero")
@example(dt=float(np.finfo(np.float32).smallest_subnormal)).via("smallest subnormal")
@example(dt=float(np.finfo(np.float32).max)).via("largest float32")
@example(dt=float(np.float32(1 / 60))).via("a 60 Hz frame")
def test_float32_bits_of_dt_survive_exactly(dt):
    message = FrameMessage(1, FrameInput(dt, IDENTITY))
    sent = f32_bits(message.inputs.dt)
    assert struct.unpack_from("<I", encode(message, SESSION), HEADER.size)[0] == sent
    assert f32_bits(decode(encode(message, SESSION, MASTER), SESSION, MEMBER).inputs.dt) == sent


def test_a_counter_the_table_does_not_know_crosses_the_wire_beside_the_known_ones():
    """A newer build's counter needs no new wire version: its entry is read whatever its id
    (the master then skips it), and the known rows keep their values, in the order sent."""
    known = tuple((row.id, (3,) * (2 if row.per_class else row.values)) for row in COUNTERS)
    report = ReportMessage(4, "front", DIGEST, 9, 0, COST, counters=(
        (4242, (1, 2, 3)), *known, (MAX_ID, ())))
    data = encode(report, SESSION, MEMBER)
    assert HEADER.unpack_from(data)[1] == VERSION == 15  # operators and confirmers, not counters
    assert decode(data, SESSION, MEMBER) == report
    assert report_body(counters=counter_tail(*report.counters)).endswith(
        counter_tail(*report.counters))


def test_info_message_is_made_from_a_gpu_description_and_gives_it_back():
    gpu = {"device": 2, "kind": "hardware", "renderer": "NVIDIA H100\u2122 80GB",
           "vendor": "NVIDIA Corporation", "version": "4.6.0 NVIDIA 580.65" + "0" * 300}
    message = InfoMessage.of_gpu(7, "front", gpu, swap_locked=True, nonce=U64)
    assert message.renderer == "NVIDIA H100? 80GB" and len(message.version) == MAX_TEXT
    assert (message.swap_locked, message.nonce) == (True, U64)
    assert decode(encode(message, SESSION, MEMBER), SESSION, MEMBER) == message
    assert message.gpu() == {**gpu, "renderer": message.renderer, "version": message.version,
                             "engine": "gs_tf", "engine_probed": False}
    assert InfoMessage.of_gpu(0, "left", {**gpu, "kind": "software"}).gpu()["kind"] == "software"
    assert message.gpu()["engine"] == "gs_tf"  # the scene's default path
    compute = InfoMessage.of_gpu(3, "left", gpu, engine=Engine.COMPUTE)
    assert decode(encode(compute, SESSION, MEMBER), SESSION, MEMBER).gpu()["engine"] == "compute"
    probed = InfoMessage.of_gpu(3, "left", gpu, engine=Engine.COMPUTE, auto=True)
    assert decode(encode(probed, SESSION, MEMBER), SESSION, MEMBER).gpu()["engine_probed"]


def test_kind_command_and_status_numbers_are_fixed():
    """They are wire values: renumbering one is a new version."""
    assert {k.name: k.value for k in Kind} == {
        "FRAME": 1, "REPORT": 2, "CONTROL": 3, "SNAPSHOT": 4, "TRACKING": 5, "CHUNK": 6,
        "INFO": 7, "DISPLAY": 8, "INFO_REQUEST": 9, "STATE_REQUEST": 10, "BLOCK_REQUEST": 11,
        "BLOCK_REPLY": 12}
    assert {q.name: q.value for q in BlockQuery} == {"TREE": 1, "HISTORY": 2, "RECORDS": 3,
                                                     "DIGEST": 4}
    assert envelope.MASTER_KINDS == MASTER_KINDS
    assert {c.name: c.value for c in Command} == {"RESYNC": 1, "STOP": 2, "SWAP": 3,
                                                  "WELCOME": 4}
    assert {s.name: s.value for s in Status} == {"STEPPED": 0, "RESYNCED": 1, "REPEATED": 2,
                                                 "JOINED": 3, "BEHIND": 4}


def test_crafted_bytes_match_encode():
    """The layout these tests craft by hand is the one `encode` writes."""
    assert HEADER.size == PAYLOAD_AT == 36
    assert encode(ControlMessage(9, Command.STOP), SESSION) == craft(Kind.CONTROL, STOP_BODY,
                                                                     frame=9)
    resync = ControlMessage(3, Command.RESYNC, "left", "front", DIGEST, confirmer="right")
    assert encode(resync, SESSION, run_id=U64) == craft(Kind.CONTROL, control_body(
        Command.RESYNC, b"left", b"front", bytes.fromhex(DIGEST), confirmer=b"right"),
        frame=3, run_id=U64)
    frame = FrameMessage(1, FrameInput(np.float32(1 / 60), MATRIX), params=(0.25,))
    assert encode(frame, SESSION) == craft(Kind.FRAME, frame_body(
        f32_bits(1 / 60), MATRIX, params=(0.25,)))
    info = InfoMessage(1, "front", 0, True, "llvmpipe", "Mesa", "4.5 Mesa", True, U64 - 1)
    assert encode(info, SESSION) == craft(Kind.INFO, info_body(flags=0x03, nonce=U64 - 1))
    assert encode(InfoRequest(4, "front", REQUEST_NONCE), SESSION) == craft(
        Kind.INFO_REQUEST, name(b"front") + struct.pack("<Q", REQUEST_NONCE), frame=4)
    assert encode(StateRequest(6, "left", DIGEST, nonce=REQUEST_NONCE), SESSION) == craft(
        Kind.STATE_REQUEST, state_request_body(), frame=6)
    blocks = BlockRequest(2, "left", DIGEST, BlockQuery.RECORDS, 0, (3, 9), "front", 1)
    assert encode(blocks, SESSION) == craft(Kind.BLOCK_REQUEST, block_request_body()[:-len(
        asked())] + asked(b"front", 1), frame=2)


def test_crafted_signatures_match_encode():
    """The master signs header and payload with Ed25519 (deterministic, so byte-exact); the
    HMAC covers all that; the other kinds carry the HMAC alone."""
    welcome = ControlMessage(2, Command.WELCOME, "front", nonce=U64)
    assert encode(welcome, SESSION, MASTER, 5) == by_master(
        Kind.CONTROL, control_body(Command.WELCOME, b"front", nonce=U64), frame=2, run_id=5)
    frame = FrameMessage(1, FrameInput(np.float32(1 / 60), MATRIX))
    assert encode(frame, SESSION, MASTER) == by_master(Kind.FRAME, frame_body(
        f32_bits(1 / 60), MATRIX))
    assert encode(InfoRequest(4, "front", REQUEST_NONCE), SESSION, MASTER, U64) == by_master(
        Kind.INFO_REQUEST, name(b"front") + struct.pack("<Q", REQUEST_NONCE), frame=4,
        run_id=U64)
    report = ReportMessage(1, "front", DIGEST, 1, 2, COST, 5, Status.BEHIND,
                           counters=((1, (0, 4)), (2, (7,)), (999, ())))
    assert encode(report, SESSION, MEMBER, 1) == by_member(
        Kind.REPORT, report_body(status=4, counters=counter_tail(
            (1, (0, 4)), (2, (7,)), (999, ()))), run_id=1)
    assert encode(StateRequest(6, "left", DIGEST, nonce=REQUEST_NONCE), SESSION,
                  MEMBER) == by_member(Kind.STATE_REQUEST, state_request_body(), frame=6)


@pytest.mark.parametrize("message", MEMBER_EDGE_MESSAGES.values(),
                         ids=MEMBER_EDGE_MESSAGES.keys())
def test_the_other_kinds_carry_only_the_hmac_whoever_sends_them(message):
    data = encode(message, SESSION, MASTER)
    assert data == encode(message, SESSION, MEMBER)
    assert data[6] == SIGNED
    assert decode_envelope(data, SESSION, MEMBER).from_master is False


@pytest.mark.parametrize("key", ["frame", "stop", "welcome", "info-request"])
def test_a_member_cannot_encode_the_masters_kinds(key):
    with pytest.raises(ValueError, match="no master signing key"):
        encode(EDGE_MESSAGES[key], SESSION, MEMBER)


@pytest.mark.parametrize("run_id", [-1, 2**64])
def test_encode_refuses_a_run_id_beyond_64_bits(run_id):
    with pytest.raises(ValueError, match="run id"):
        encode(EDGE_MESSAGES["report"], SESSION, MEMBER, run_id)


@pytest.mark.parametrize("message, match", [
    (ReportMessage(-1, "front", DIGEST, 0, 0, NO_COST), "frame"),
    (InfoRequest(2**64, "front"), "frame"),
    (FrameMessage(1, FrameInput(0.0, IDENTITY), params=(0.0,) * (MAX_PARAMS + 1)),
     "at most 32"),
    (ReportMessage(1, "bad/name", DIGEST, 0, 0, NO_COST), "node name"),
    (ReportMessage(1, "", DIGEST, 0, 0, NO_COST), "node name"),
    (ReportMessage(1, "front", DIGEST, 0, 0, (0, 0)), f"times the {len(PHASES)} phases"),
    (ControlMessage(1, Command.RESYNC, "x" * 33, "front"), "node name"),
    (ControlMessage(1, Command.RESYNC, "left", "front", "XY" * 16), "hex digits"),
    (ControlMessage(1, Command.RESYNC, "left", "front", DIGEST[:-1]), "hex digits"),
    (ControlMessage(1, Command.WELCOME, "front", nonce=2**64), "nonce"),
    (ControlMessage(1, Command.WELCOME, "front", nonce=-1), "nonce"),
    (InfoMessage(1, "front", 2**16, False, "r", "v", "4.6"), "device index"),
    (InfoMessage(1, "front", 0, False, "r" * (MAX_TEXT + 1), "v", "4.6"), "renderer"),
    (InfoMessage(1, "front", 0, False, "r", "v\u00e9", "4.6"), "vendor"),
    (InfoMessage(1, "front", 0, False, "r", "v", "4.6\n"), "version"),
    (InfoMessage(1, "", 0, False, "r", "v", "4.6"), "node name"),
    (InfoMessage(1, "front", 0, False, "r", "v", "4.6", nonce=2**64), "nonce"),
    (InfoRequest(1, "a b"), "node name"),
    (StateRequest(1, "left", ""), "hex digits"),
    (StateRequest(1, "left", DIGEST.upper()), "hex digits"),
    (StateRequest(1, "x" * 33, DIGEST), "node name"),
    (DisplayMessage(1, "front", Phase.DRAWN, -1), "time_ns"),
    (SnapshotHeader(1, 0, 10, 0, DIGEST, np.zeros(0, EMITTER_DTYPE)), "chunks of 1 to"),
    (SnapshotHeader(1, 0, MAX_PARTICLES + 1, 1, DIGEST, np.zeros(0, EMITTER_DTYPE)),
     "at most"),
    (SnapshotHeader(1, 0, 1, 1, "XY" * 16, np.zeros(0, EMITTER_DTYPE)), "hex digits"),
    (SnapshotChunk(1, 0, bytes(41)), "whole 40-byte records"),
    (SnapshotChunk(1, 0, b""), "whole 40-byte records"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, sample=SAMPLE), "at most the 1 live"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=tuple(
        (1000 + i, ()) for i in range(MAX_ENTRIES + 1))), f"at most {MAX_ENTRIES} counters"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((0, (1,)),)), "id must be"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((MAX_ID + 1, (1,)),)),
     "id must be"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((9, (1,)), (9, (2,)))),
     "each counter once"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((2, (1, 1)),)),
     r"\(capacity_drops\) has 1 value\(s\), got 2"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((9, (0,) * 65),)),
     "at most 64"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((2, (2**32,)),)),
     r"in \[0, 2\*\*32\)"),
    (ReportMessage(1, "front", DIGEST, 1, 0, NO_COST, counters=((2, (-1,)),)),
     r"in \[0, 2\*\*32\)"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.RECORDS, 0, (5, 3)), "ascending"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.RECORDS, 0, ()), "may name none"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.TREE, 3), "part 3"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.HISTORY, 0, (1,)), "part 0"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.TREE, 0, tuple(range(MAX_BLOCK_INDICES + 1))),
     "ascending indices"),
    (BlockRequest(1, "left", DIGEST, BlockQuery.TREE, 0, (2**32,)), "ascending indices"),
    (BlockReply(1, "left", BlockQuery.TREE, 1, 0, 0, 0, bytes(15)), "whole items"),
    (BlockReply(1, "left", BlockQuery.RECORDS, 0, 0, 0, 0, bytes(MAX_BLOCK_BYTES + 40)),
     "whole items"),
    (BlockReply(1, "left", BlockQuery.TREE, 1, 0, MAX_PARTICLES + 1, 0, b""), "counts"),
    (BlockReply(1, "left", BlockQuery.HISTORY, 1, 0, 0, 0, b"",
                tuple(HistoryFrame(f, 0, 0) for f in range(65))), "history frames"),
])
def test_encode_refuses_what_decode_would_reject(message, match):
    with pytest.raises(ValueError, match=match):
        encode(message, SESSION)


# -- every rejection -----------------------------------------------------------------------

STOP = craft(Kind.CONTROL, STOP_BODY)
SIGNED_STOP = by_master(Kind.CONTROL, STOP_BODY)
STOP_UNDER_MASTER_SIGNATURE = SIGNED_STOP[:-HMAC_BYTES]  # what a member can HMAC again
SIGNED_REPORT = by_member(Kind.REPORT, report_body())
SIGNED_FRAME = encode(EDGE_MESSAGES["frame-max-params"], SESSION, MASTER)
VERSION_3_STOP = with_hmac(struct.pack("<4sBBBBQQI", b"CVSM", 3, Kind.CONTROL, SIGNED, 0,
                                       session_id(SESSION), 1, 3) + b"\x02\x00\x00")
NAN32 = 0x7FC00000

REJECTIONS = [
    # (id, bytes, the receiver's credentials, reason)
    ("empty", b"", None, "truncated"),
    ("header-minus-one", STOP[:HEADER.size - 1], None, "truncated"),
    ("magic-only", b"CVSM", MEMBER, "truncated"),
    ("magic", b"CVSN" + STOP[4:], None, "bad-magic"),
    ("magic-lowercase", b"cvsm" + SIGNED_STOP[4:], MEMBER, "bad-magic"),
    ("version-0", craft(Kind.CONTROL, STOP_BODY, version=0), None, "bad-version"),
    ("version-3-layout", VERSION_3_STOP, MEMBER, "bad-version"),
    ("version-next", craft(Kind.CONTROL, STOP_BODY, version=VERSION + 1), None,
     "bad-version"),
    # a frame log reads its older frames itself (cavesim.core.framelog): the wire never does
    ("frame-version-before", craft(Kind.FRAME, frame_body(), version=VERSION - 1), None,
     "bad-version"),
    ("kind-0", craft(0, STOP_BODY), None, "bad-kind"),
    ("kind-next", craft(max(Kind) + 1, STOP_BODY), None, "bad-kind"),
    ("kind-255", by_member(255, STOP_BODY), MEMBER, "bad-kind"),
    ("other-session", craft(Kind.CONTROL, STOP_BODY, session="other"), None, "wrong-session"),
    ("other-session-signed", by_master(Kind.CONTROL, STOP_BODY, session="other"), MEMBER,
     "wrong-session"),
    # flags: 0, SIGNED or SIGNED | MASTER_SIGNED, and the reserved byte 0
    ("master-signed-flag-alone", craft(Kind.CONTROL, STOP_BODY, flags=MASTER_SIGNED), None,
     "bad-flags"),
    ("master-signature-without-hmac", craft(Kind.CONTROL, STOP_BODY,
                                            master_key=MASTER.master_private), MEMBER,
     "bad-flags"),
    ("flag-4", craft(Kind.REPORT, report_body(), flags=0x04), None, "bad-flags"),
    ("flags-signed-and-128", by_member(Kind.REPORT, report_body(), flags=0x81), MEMBER,
     "bad-flags"),
    ("flags-both-signatures-and-4", by_master(Kind.CONTROL, STOP_BODY, flags=0x07), MEMBER,
     "bad-flags"),
    ("reserved-1", craft(Kind.CONTROL, STOP_BODY, reserved=1), None, "bad-flags"),
    ("reserved-128-signed", by_master(Kind.CONTROL, STOP_BODY, reserved=0x80), MEMBER,
     "bad-flags"),
    # lengths: the header's payload length and the trailer its flags announce
    ("one-byte-short", STOP[:-1], None, "bad-length"),
    ("one-byte-long", STOP + b"\x00", None, "bad-length"),
    ("length-oversized", craft(Kind.CONTROL, STOP_BODY, length=2**32 - 1), None,
     "bad-length"),
    ("length-zero", craft(Kind.CONTROL, STOP_BODY, length=0), None, "bad-length"),
    ("hmac-cut-short", SIGNED_STOP[:-1], MEMBER, "bad-length"),
    ("hmac-missing", SIGNED_STOP[:-HMAC_BYTES], MEMBER, "bad-length"),
    ("master-signature-missing", craft(Kind.CONTROL, STOP_BODY, flags=SIGNED | MASTER_SIGNED,
                                       secret=MASTER.secret), MEMBER, "bad-length"),
    ("signed-flag-cleared", flipped(SIGNED_REPORT, 6, 0), MEMBER, "bad-length"),
    ("master-signed-flag-cleared", flipped(SIGNED_STOP, 6, 1), MEMBER, "bad-length"),
    ("master-signed-flag-on-a-report", flipped(SIGNED_REPORT, 6, 1), MEMBER, "bad-flags"),
    ("unsigned", STOP, MEMBER, "unsigned"),
    ("unsigned-frame", encode(EDGE_MESSAGES["frame"], SESSION), MEMBER, "unsigned"),
    ("unsigned-report-at-the-master", craft(Kind.REPORT, report_body()), MASTER, "unsigned"),
    # the HMAC covers everything before it: header (run id too), payload, master's signature
    ("other-sessions-secret", craft(Kind.REPORT, report_body(), secret=OTHER.secret), MEMBER,
     "bad-signature"),
    ("other-sessions-master", craft(Kind.CONTROL, STOP_BODY, secret=OTHER.secret,
                                    master_key=OTHER.master_private), MEMBER, "bad-signature"),
    ("flipped-payload-bit", flipped(SIGNED_STOP, PAYLOAD_AT), MEMBER, "bad-signature"),
    ("flipped-frame-bit", flipped(SIGNED_STOP, FRAME_AT), MEMBER, "bad-signature"),
    ("flipped-run-id-bit", flipped(SIGNED_STOP, RUN_ID_AT), MEMBER, "bad-signature"),
    ("flipped-top-run-id-bit", flipped(SIGNED_REPORT, RUN_ID_AT + 7, 7), MASTER,
     "bad-signature"),
    ("flipped-master-signature-bit", flipped(SIGNED_STOP, -HMAC_BYTES - 1, 7), MEMBER,
     "bad-signature"),
    ("flipped-hmac-bit", flipped(SIGNED_STOP, -1, 7), MEMBER, "bad-signature"),
    # a member's card must be the master's, and its signature the card's key's
    ("card-of-another-master", encode(EDGE_MESSAGES["report"], SESSION, Credentials(
        MASTER.secret, OTHER.master_public, OTHER.master_private).issue("wall", "front")),
     MEMBER, "bad-member-signature"),
    # the master's signature covers header and payload: a member can HMAC, not sign
    ("master-signature-of-another-key-pair", craft(Kind.CONTROL, STOP_BODY,
                                                   secret=MASTER.secret,
                                                   master_key=OTHER.master_private), MEMBER,
     "bad-master-signature"),
    ("another-key-pair-at-the-master", craft(Kind.FRAME, frame_body(), secret=MASTER.secret,
                                             master_key=OTHER.master_private), MASTER,
     "bad-master-signature"),
    ("another-key-pair-on-a-report", craft(Kind.REPORT, report_body(), secret=MASTER.secret,
                                           master_key=OTHER.master_private), MEMBER,
     "bad-flags"),  # only the master's kinds carry its signature
    ("re-hmaced-after-a-payload-change", with_hmac(flipped(STOP_UNDER_MASTER_SIGNATURE,
                                                           PAYLOAD_AT)), MEMBER,
     "bad-master-signature"),
    ("re-hmaced-into-another-run", with_hmac(flipped(STOP_UNDER_MASTER_SIGNATURE, RUN_ID_AT)),
     MEMBER, "bad-master-signature"),
    ("re-hmaced-after-a-signature-change", with_hmac(flipped(STOP_UNDER_MASTER_SIGNATURE, -1)),
     MEMBER, "bad-master-signature"),
    ("frame-by-member", by_member(Kind.FRAME, frame_body()), MEMBER, "not-from-master"),
    ("control-by-member", by_member(Kind.CONTROL, STOP_BODY), MEMBER, "not-from-master"),
    ("welcome-by-member", by_member(Kind.CONTROL, control_body(Command.WELCOME, b"front",
                                                               nonce=7)), MEMBER,
     "not-from-master"),
    ("info-request-by-member", by_member(Kind.INFO_REQUEST, name(b"front")), MEMBER,
     "not-from-master"),
    ("control-by-member-at-the-master", by_member(Kind.CONTROL, STOP_BODY), MASTER,
     "not-from-master"),
    ("master-signature-stripped", strip_master_signature(SIGNED_STOP), MEMBER,
     "not-from-master"),
    ("frame-by-member-refused-before-its-payload", by_member(Kind.FRAME, frame_body()[:-1]),
     MEMBER, "not-from-master"),
    ("unexpected-hmac", SIGNED_REPORT, None, "unexpected-signature"),
    ("unexpected-master-signature", SIGNED_STOP, None, "unexpected-signature"),
    # payloads
    ("frame-too-short", craft(Kind.FRAME, frame_body()[:-1]), None, "bad-payload"),
    ("frame-without-events", craft(Kind.FRAME, frame_body(events=None)), None, "bad-payload"),
    ("frame-unknown-event", craft(Kind.FRAME, frame_body(events=0x02)), None, "bad-value"),
    ("tracking-pause-without-controls", craft(Kind.TRACKING, TRACKING_BODY.pack(
        *(0.0,) * 14, 0, *(0.0,) * 4, 1, 0x01 | 0x04, 0)), None, "bad-value"),
    ("tracking-resets-without-controls", craft(Kind.TRACKING, TRACKING_BODY.pack(
        *(0.0,) * 14, 0, *(0.0,) * 4, 1, 0x01, 1)), None, "bad-value"),
    ("tracking-unknown-flag", craft(Kind.TRACKING, TRACKING_BODY.pack(
        *(0.0,) * 14, 0, *(0.0,) * 4, 1, 0x10, 0)), None, "bad-value"),
    ("frame-count-above-params", craft(Kind.FRAME, frame_body(params=(1.0, 2.0), count=3)),
     None, "bad-payload"),
    ("frame-count-below-params", craft(Kind.FRAME, frame_body(params=(1.0, 2.0), count=1)),
     None, "bad-payload"),
    ("frame-33-params", craft(Kind.FRAME, frame_body(params=(0.0,) * 33)), None,
     "bad-payload"),
    ("frame-signed-count-mismatch", by_master(Kind.FRAME, frame_body(params=(1.0,), count=0)),
     MEMBER, "bad-payload"),
    ("report-name-not-ascii", craft(Kind.REPORT, report_body(b"fr\xc3\xb6nt")), None,
     "bad-payload"),
    ("report-name-slash", craft(Kind.REPORT, report_body(b"front/x")), None, "bad-payload"),
    ("report-name-empty", craft(Kind.REPORT, report_body(b"")), None, "bad-payload"),
    ("report-name-33", craft(Kind.REPORT, report_body(b"a" * 33)), None, "bad-payload"),
    ("report-name-past-end", craft(Kind.REPORT, b"\x09front"), None, "bad-payload"),
    ("report-empty", craft(Kind.REPORT, b""), None, "bad-payload"),
    ("report-stray-byte", craft(Kind.REPORT, report_body(extra=b"\x00")), None,
     "bad-payload"),
    ("report-short", craft(Kind.REPORT, report_body()[:-1]), None, "bad-payload"),
    ("report-no-counter-count", craft(Kind.REPORT, report_body(counters=b"")), None,
     "bad-payload"),
    ("report-counters-beyond-max", craft(Kind.REPORT, report_body(counters=counter_tail(
        *((id_, (1,)) for id_ in range(1000, 1001 + MAX_ENTRIES))))), None, "bad-payload"),
    ("report-counters-fewer-than-counted", craft(Kind.REPORT, report_body(
        counters=counter_tail((2, (1,)), count=2))), None, "bad-payload"),
    ("report-counter-header-short", craft(Kind.REPORT, report_body(
        counters=b"\x01\x02\x00")), None, "bad-payload"),
    ("report-counter-values-short", craft(Kind.REPORT, report_body(
        counters=counter_tail((1, (1, 2)))[:-1])), None, "bad-payload"),
    ("report-counter-id-0", craft(Kind.REPORT, report_body(counters=counter_tail((0, (1,))))),
     None, "bad-payload"),
    ("report-counter-twice", craft(Kind.REPORT, report_body(counters=counter_tail(
        (2, (1,)), (2, (1,))))), None, "bad-payload"),
    ("report-counter-known-wrong-width", craft(Kind.REPORT, report_body(
        counters=counter_tail((2, (1, 2))))), None, "bad-payload"),
    ("report-counter-class-beyond-max", craft(Kind.REPORT, report_body(counters=counter_tail(
        (1, (0,) * (MAX_PARTICLE_CLASSES + 1))))), None, "bad-payload"),
    ("report-counter-per-class-none", craft(Kind.REPORT, report_body(
        counters=counter_tail((1, ())))), None, "bad-payload"),
    ("report-counter-unknown-beyond-max", craft(Kind.REPORT, report_body(
        counters=counter_tail((4242, (0,) * (MAX_VALUES + 1))))), None, "bad-payload"),
    ("report-sample-beyond-live", craft(Kind.REPORT, report_body(extra=sample_tail(2))),
     None, "bad-payload"),
    ("report-sample-beyond-max", craft(Kind.REPORT, report_body(
        extra=sample_tail(MAX_SAMPLE + 1), particles=10**6)), None, "bad-payload"),
    ("report-sample-short", craft(Kind.REPORT, report_body(extra=sample_tail(1, 0))), None,
     "bad-payload"),
    ("report-sample-stray-byte", craft(Kind.REPORT, report_body(extra=sample_tail(1) + b"\0")),
     None, "bad-payload"),
    ("control-empty", craft(Kind.CONTROL, b""), None, "bad-payload"),
    ("control-command-0", craft(Kind.CONTROL, control_body(0)), None, "bad-payload"),
    ("control-command-5", craft(Kind.CONTROL, control_body(5)), None, "bad-payload"),
    ("control-stray-byte", craft(Kind.CONTROL, STOP_BODY + b"\x00"), None, "bad-payload"),
    ("control-nonce-short", craft(Kind.CONTROL, STOP_BODY[:-1]), None, "bad-payload"),
    ("control-version-3-layout", craft(Kind.CONTROL, b"\x02\x00\x00"), None, "bad-payload"),
    ("control-source-missing", craft(Kind.CONTROL, b"\x01" + name(b"left")), None,
     "bad-payload"),
    ("control-target-tab", craft(Kind.CONTROL, control_body(Command.RESYNC, b"le\tft",
                                                            b"front")), None, "bad-payload"),
    ("snapshot-too-short", craft(Kind.SNAPSHOT, snapshot_body()[:-1]), None, "bad-payload"),
    ("snapshot-emitters-missing", craft(Kind.SNAPSHOT, snapshot_body(emitters=1)), None,
     "bad-payload"),
    ("snapshot-stray-byte", craft(Kind.SNAPSHOT, snapshot_body() + b"\x00"), None,
     "bad-payload"),
    ("snapshot-too-many-particles", craft(Kind.SNAPSHOT, snapshot_body(
        particles=MAX_PARTICLES + 1)), None, "bad-payload"),
    ("snapshot-too-many-emitters", craft(Kind.SNAPSHOT, snapshot_body(
        emitters=MAX_EMITTERS + 1) + bytes(16 * (MAX_EMITTERS + 1))), None,
     "bad-payload"),
    ("snapshot-chunk-size-0", craft(Kind.SNAPSHOT, snapshot_body(chunk=0)), None,
     "bad-payload"),
    ("snapshot-chunk-size-too-big", craft(Kind.SNAPSHOT, snapshot_body(
        chunk=MAX_CHUNK_PARTICLES + 1)), None, "bad-payload"),
    ("chunk-too-short", craft(Kind.CHUNK, b"\x00" * 3), None, "bad-payload"),
    ("chunk-empty", craft(Kind.CHUNK, struct.pack("<I", 0)), None, "bad-payload"),
    ("chunk-partial-record", craft(Kind.CHUNK, struct.pack("<I", 0) + bytes(41)), None,
     "bad-payload"),
    ("chunk-index-beyond-any-snapshot", craft(Kind.CHUNK, struct.pack(
        "<I", MAX_PARTICLES) + bytes(40)), None, "bad-value"),
    ("kind-frame-with-report-payload", craft(Kind.FRAME, report_body()), None, "bad-payload"),
    ("info-empty", craft(Kind.INFO, b""), None, "bad-payload"),
    ("info-name-slash", craft(Kind.INFO, info_body(node=b"a/b")), None, "bad-payload"),
    ("info-body-short", craft(Kind.INFO, name(b"front") + bytes(10)), None, "bad-payload"),
    ("info-string-missing", craft(Kind.INFO, info_body(texts=(b"r", b"v"))), None,
     "bad-payload"),
    ("info-string-past-end", craft(Kind.INFO, info_body()[:-1]), None, "bad-payload"),
    ("info-stray-byte", craft(Kind.INFO, info_body(extra=b"\x00")), None, "bad-payload"),
    ("display-short", craft(Kind.DISPLAY, name(b"front") + bytes([1]) + bytes(7)), None,
     "bad-payload"),
    ("info-request-empty", craft(Kind.INFO_REQUEST, b""), None, "bad-payload"),
    ("info-request-stray-byte", craft(Kind.INFO_REQUEST, name(b"front") + b"\x00"), None,
     "bad-payload"),
    ("info-request-name-slash", craft(Kind.INFO_REQUEST, name(b"a/b")), None, "bad-payload"),
    ("info-request-signed-name-empty", by_master(Kind.INFO_REQUEST, name(b"")), MEMBER,
     "bad-payload"),
    ("state-request-empty", craft(Kind.STATE_REQUEST, b""), None, "bad-payload"),
    ("state-request-without-nonce", craft(Kind.STATE_REQUEST, name(b"left") + bytes.fromhex(
        DIGEST)), None, "bad-payload"),
    ("state-request-asker-slash", craft(Kind.STATE_REQUEST, name(b"left") + bytes.fromhex(
        DIGEST) + asked(b"a/b")), None, "bad-payload"),
    ("block-request-without-nonce", craft(Kind.BLOCK_REQUEST, block_request_body()[:-len(
        asked())]), None, "bad-payload"),
    ("state-request-digest-short", craft(Kind.STATE_REQUEST, state_request_body()[:-1]), None,
     "bad-payload"),
    ("state-request-stray-byte", craft(Kind.STATE_REQUEST, state_request_body() + b"\x00"),
     None, "bad-payload"),
    ("state-request-name-33", craft(Kind.STATE_REQUEST, state_request_body(b"a" * 33)), None,
     "bad-payload"),
    ("block-request-short", craft(Kind.BLOCK_REQUEST, block_request_body()[:-1]), None,
     "bad-payload"),
    ("block-request-head-short", craft(Kind.BLOCK_REQUEST, name(b"left") + bytes(5)), None,
     "bad-payload"),
    ("block-request-too-many", craft(Kind.BLOCK_REQUEST, block_request_body(
        indices=range(MAX_BLOCK_INDICES + 1))), None, "bad-payload"),
    ("block-request-count-lies", craft(Kind.BLOCK_REQUEST, block_request_body(count=3)), None,
     "bad-payload"),
    ("block-reply-head-short", craft(Kind.BLOCK_REPLY, name(b"left") + bytes(10)), None,
     "bad-payload"),
    ("block-reply-partial-item", craft(Kind.BLOCK_REPLY, block_reply_body(data=bytes(17))),
     None, "bad-payload"),
    ("block-reply-frames-missing", craft(Kind.BLOCK_REPLY, block_reply_body(
        query=BlockQuery.HISTORY, frames=3, data=b"")[:-1]), None, "bad-payload"),
    ("block-reply-too-large", craft(Kind.BLOCK_REPLY, block_reply_body(
        query=BlockQuery.RECORDS, part=0, data=bytes(MAX_BLOCK_BYTES + 40))), None,
     "bad-payload"),
    # values
    ("dt-nan", craft(Kind.FRAME, frame_body(dt_bits=NAN32)), None, "bad-value"),
    ("dt-inf", craft(Kind.FRAME, frame_body(dt_bits=0x7F800000)), None, "bad-value"),
    ("dt-negative", craft(Kind.FRAME, frame_body(dt_bits=f32_bits(-1 / 60))), None,
     "bad-value"),
    ("matrix-not-integer", craft(Kind.FRAME, frame_body(matrix=[[1.5, 0, 0], [0, 1, 0],
                                                                [0, 0, 1]])), None, "bad-value"),
    ("matrix-nan", craft(Kind.FRAME, frame_body(matrix=[[1, 0, math.nan], [0, 1, 0],
                                                        [0, 0, 1]])), None, "bad-value"),
    ("matrix-2**24", craft(Kind.FRAME, frame_body(matrix=[[2**24, 0, 0], [0, 1, 0],
                                                          [0, 0, 1]])), None, "bad-value"),
    ("matrix-last-row", craft(Kind.FRAME, frame_body(matrix=np.ones((3, 3)))), None,
     "bad-value"),
    ("wand-position-nan", craft(Kind.FRAME, frame_body(position=(0.0, math.nan, 0.0))), None,
     "bad-value"),
    ("wand-orientation-inf", craft(Kind.FRAME, frame_body(orientation=(math.inf, 0, 0, 1))),
     None, "bad-value"),
    ("wand-axes-nan", craft(Kind.FRAME, frame_body(axes=(0.0, 0.0, 0.0, math.nan))), None,
     "bad-value"),
    ("head-position-nan", craft(Kind.FRAME, frame_body(head_position=(math.nan, 0.0, 1.7))),
     None, "bad-value"),
    ("param-nan", craft(Kind.FRAME, frame_body(params=(1.0, math.nan))), None, "bad-value"),
    ("param-signed-inf", by_master(Kind.FRAME, frame_body(params=(-math.inf,))), MEMBER,
     "bad-value"),
    ("report-status-5", craft(Kind.REPORT, report_body(status=5)), None, "bad-value"),
    ("info-flag-16", craft(Kind.INFO, info_body(flags=16)), None, "bad-value"),
    ("control-engine-3", craft(Kind.CONTROL, control_body(Command.WELCOME, b"front",
                                                         engine=3)), None, "bad-value"),
    ("info-string-control", craft(Kind.INFO, info_body(texts=(b"r\n", b"v", b"4"))), None,
     "bad-value"),
    ("info-string-utf8", craft(Kind.INFO, info_body(texts=(b"r", "v\u00e9".encode(), b"4"))),
     None, "bad-value"),
    ("info-string-del", craft(Kind.INFO, info_body(texts=(b"r", b"v", b"\x7f"))), None,
     "bad-value"),
    ("display-phase-3", craft(Kind.DISPLAY, name(b"front") + bytes([3]) + bytes(8)), None,
     "bad-value"),
    ("block-request-query-5", craft(Kind.BLOCK_REQUEST, block_request_body(query=5)), None,
     "bad-value"),
    ("block-request-level-3", craft(Kind.BLOCK_REQUEST, block_request_body(
        query=BlockQuery.TREE, part=3)), None, "bad-value"),
    ("block-request-descending", craft(Kind.BLOCK_REQUEST, block_request_body(
        indices=(9, 3))), None, "bad-value"),
    ("block-request-repeated", craft(Kind.BLOCK_REQUEST, block_request_body(
        indices=(3, 3))), None, "bad-value"),
    ("block-request-records-none", craft(Kind.BLOCK_REQUEST, block_request_body(
        indices=())), None, "bad-value"),
    ("block-reply-history-part-0", craft(Kind.BLOCK_REPLY, block_reply_body(
        query=BlockQuery.HISTORY, part=0)), None, "bad-value"),
    ("block-reply-too-many-particles", craft(Kind.BLOCK_REPLY, block_reply_body(
        particles=MAX_PARTICLES + 1)), None, "bad-value"),
    ("block-reply-65-frames", craft(Kind.BLOCK_REPLY, block_reply_body(
        query=BlockQuery.HISTORY, frames=65, data=b"")), None, "bad-value"),
]


@pytest.mark.parametrize("data, credentials, reason", [case[1:] for case in REJECTIONS],
                         ids=[case[0] for case in REJECTIONS])
def test_each_crafted_input_is_rejected_for_its_reason(data, credentials, reason):
    assert reason_of(data, SESSION, credentials) == reason


def test_every_reason_decode_raises_has_a_crafted_case():
    """A new ProtocolError reason in the envelope or a payload needs a case in REJECTIONS."""
    wire = Path(envelope.__file__).parent
    source = "".join(path.read_text() for path in [wire / "envelope.py",
                                                   *(wire / "payloads").glob("*.py")])
    raised = set(re.findall(r'ProtocolError\(\s*"([a-z-]+)"', source))
    checked_by_receivers = {"wrong-signer"}  # Envelope.check_signer: tests/unit/test_identity.py
    assert raised - checked_by_receivers == {case[3] for case in REJECTIONS}


def flip_reason(signed: bytes, index: int, bit: int, hmac_renewed: bool = False) -> str:
    """Why `signed` with bit `bit` of byte `index` flipped must be rejected; with
    `hmac_renewed` its HMAC was made afresh after the flip (as any member can), so what the
    HMAC would catch falls to the master's signature."""
    caught = "bad-master-signature" if hmac_renewed else "bad-signature"
    if index < 4:
        return "bad-magic"
    if index == 4:
        return "bad-version"
    if index == 5:  # the kind may turn into another known kind, which a signature catches
        kind = signed[5] ^ (1 << bit)
        if kind not in set(Kind):
            return "bad-kind"
        master_signed = signed[6] & MASTER_SIGNED
        return "bad-flags" if master_signed and kind not in MASTER_KINDS else caught
    if index == 6:  # allowed flags that announce another trailer than the one attached
        flags = signed[6] ^ (1 << bit)
        allowed = (0, SIGNED, SIGNED | (MASTER_SIGNED if signed[5] in MASTER_KINDS
                                        else MEMBER_SIGNED))
        return "bad-length" if flags in allowed else "bad-flags"
    if index == 7:  # the reserved byte must stay 0
        return "bad-flags"
    if 8 <= index < RUN_ID_AT:
        return "wrong-session"
    if FRAME_AT + 8 <= index < PAYLOAD_AT:
        return "bad-length"
    return caught  # the run id, the frame number, the payload and the signatures


@pytest.mark.parametrize("data, index", [(SIGNED_STOP, i) for i in range(len(SIGNED_STOP))]
                         + [(SIGNED_REPORT, i) for i in range(len(SIGNED_REPORT))],
                         ids=[f"stop-by-master-{i}" for i in range(len(SIGNED_STOP))]
                         + [f"report-by-member-{i}" for i in range(len(SIGNED_REPORT))])
def test_one_flipped_bit_anywhere_in_a_signed_message_is_rejected(data, index):
    for bit in range(8):
        assert reason_of(flipped(data, index, bit), SESSION, MEMBER) == \
            flip_reason(data, index, bit), bit


@pytest.mark.parametrize("index", range(len(STOP_UNDER_MASTER_SIGNATURE)))
def test_a_flipped_bit_under_the_masters_signature_is_caught_despite_a_fresh_hmac(index):
    for bit in range(8):
        forged = with_hmac(flipped(STOP_UNDER_MASTER_SIGNATURE, index, bit))
        assert reason_of(forged, SESSION, MEMBER) == \
            flip_reason(SIGNED_STOP, index, bit, hmac_renewed=True), bit


@pytest.mark.parametrize("index", range(0, len(SIGNED_FRAME), 7))
def test_flipped_bits_of_a_signed_frame_are_rejected(index):
    for bit in (0, 3, 7):
        with pytest.raises(ProtocolError):
            decode(flipped(SIGNED_FRAME, index, bit), SESSION, MEMBER)


@given(message=master_messages)
def test_a_master_message_stripped_of_its_signature_and_re_signed_is_refused(message):
    stripped = strip_master_signature(encode(message, SESSION, MASTER))
    assert reason_of(stripped, SESSION, MEMBER) == "not-from-master"


@given(message=master_messages, master_key=master_keys)
def test_a_master_signature_of_another_key_pair_is_rejected(message, master_key):
    impostor = of_master(MASTER.secret, master_key)  # knows the secret, not the master's key
    assume(impostor.master_public != MASTER.master_public)
    assert reason_of(encode(message, SESSION, impostor), SESSION, MEMBER) == \
        "bad-master-signature"


# -- fuzzing -------------------------------------------------------------------------------

def decodes_or_rejects(data: bytes, session: str = SESSION,
                       credentials: Credentials | None = None):
    """decode's only outcomes: an envelope or ProtocolError (any other exception fails)."""
    try:
        return decode_envelope(data, session, credentials)
    except ProtocolError as e:
        assert e.reason and str(e).startswith(e.reason)
        return None


@given(data=st.binary(max_size=600), credentials=st.sampled_from([None, MEMBER, MASTER]))
def test_decode_of_arbitrary_bytes_returns_or_raises_protocol_error(data, credentials):
    decodes_or_rejects(data, SESSION, credentials)


@st.composite
def behind_a_valid_header(draw) -> tuple[bytes, Credentials | None]:
    """Arbitrary payloads under a header that passes, unsigned or signed as `encode` signs
    (with the receiver's credentials), so the payload readers get fuzzed."""
    kind = draw(st.sampled_from(Kind))
    payload = draw(st.binary(max_size=600))
    fields = {"frame": draw(frame_numbers), "run_id": draw(run_ids)}
    if draw(st.booleans()):
        sign = by_master if kind in MASTER_KINDS else by_member
        return sign(kind, payload, **fields), MEMBER
    return craft(kind, payload, **fields), None


@given(crafted=behind_a_valid_header())
def test_decode_of_arbitrary_payloads_returns_or_raises_protocol_error(crafted):
    data, credentials = crafted
    decodes_or_rejects(data, SESSION, credentials)


@given(message=all_messages, run_id=run_ids,
       changes=st.lists(mutations, min_size=1, max_size=4))
@example(message=EDGE_MESSAGES["stop"], run_id=0,
         changes=[Mutation("flip", 7.5 / len(STOP), 0xFF)])
def test_decode_of_mutated_messages_returns_or_raises_protocol_error(message, run_id,
                                                                     changes):
    data = mutate(encode(message, SESSION, run_id=run_id), changes)
    envelope = decodes_or_rejects(data)
    if envelope is not None:
        # Whatever passes is canonical: it encodes to the same bytes, so the frame log and
        # every node see one meaning (the reserved byte 7 must be 0).
        assert encode(envelope.message, SESSION, run_id=envelope.run_id) == data
    decodes_or_rejects(mutate(encode(message, SESSION, sender(message), run_id), changes),
                       SESSION, None)


@given(message=all_messages, change=mutations)
def test_any_mutation_of_a_signed_message_is_rejected(message, change):
    data = change.apply(encode(message, SESSION, sender(message)))
    with pytest.raises(ProtocolError):
        decode(data, SESSION, MEMBER)


@given(message=master_messages, changes=st.lists(mutations, min_size=1, max_size=4))
def test_a_member_cannot_forge_a_message_from_the_master(message, changes):
    """Holding the secret, a member can HMAC any bytes, but none of them pass as the
    master's: the master's signature covers its header and payload."""
    under_master_signature = encode(message, SESSION, MASTER)[:-HMAC_BYTES]
    forged = mutate(under_master_signature, changes)
    assume(forged != under_master_signature)
    envelope = decodes_or_rejects(with_hmac(forged), SESSION, MEMBER)
    assert envelope is None or not envelope.from_master


@given(message=all_messages, mine=credential_sets, theirs=credential_sets)
def test_another_sessions_secret_is_rejected(message, mine, theirs):
    assume(mine.secret != theirs.secret)
    data = encode(message, SESSION, sender(message, theirs))
    assert reason_of(data, SESSION, mine.for_members()) == "bad-signature"


@given(message=all_messages, mine=names, theirs=names,
       credentials=st.none() | credential_sets)
def test_sessions_never_decode_each_others_messages(message, mine, theirs, credentials):
    assume(mine != theirs)
    data = encode(message, theirs, sender(message, credentials))
    assert reason_of(data, mine, members_of(credentials)) == "wrong-session"


@given(message=all_messages)
def test_a_signed_message_is_unexpected_without_credentials_and_unsigned_with_them(message):
    assert reason_of(encode(message, SESSION, sender(message)), SESSION) == \
        "unexpected-signature"
    assert reason_of(encode(message, SESSION), SESSION, MEMBER) == "unsigned"
