"""The wire format on its own (no network): round trips, every rejection, and fuzzing.

Crafted inputs are built here from the documented layout (28-byte header, payload, HMAC-
SHA256 over both), not with `encode`, so the tests pin the format rather than echo it.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import re
import struct
from pathlib import Path

import numpy as np
import pytest
from cluster_helpers import (
    U64,
    Mutation,
    control_messages,
    dts,
    frame_messages,
    hmac_keys,
    info_messages,
    messages,
    mutate,
    mutations,
    names,
    report_messages,
    snapshot_messages,
)
from hypothesis import assume, example, given
from hypothesis import strategies as st

from cavesim.core.errors import ProtocolError
from cavesim.core.limits import MAX_EMITTERS, MAX_PARTICLES
from cavesim.core.wire import messages as wire
from cavesim.core.wire.messages import (
    MAX_CHUNK_PARTICLES,
    MAX_PARAMS,
    MAX_TEXT,
    VERSION,
    Command,
    ControlMessage,
    FrameMessage,
    HeadState,
    InfoMessage,
    Kind,
    ReportMessage,
    SnapshotChunk,
    SnapshotHeader,
    Status,
    TrackingMessage,
    WandState,
    decode,
    encode,
    session_id,
)
from cavesim.gpu.engine import EMITTER_DTYPE, FrameInput

SESSION = "wiretest"
KEY = b"0123456789abcdef0123456789abcdef"
OTHER_KEY = b"fedcba9876543210fedcba9876543210"
HEADER = struct.Struct("<4sBBBBQQI")  # magic, version, kind, flags, reserved, session, ...
FRAME_BODY = struct.Struct("<I9f3f4f3f4fI4fH")  # dt bits, matrix, head, wand, param count
IDENTITY = np.eye(3, dtype=np.float32)
MATRIX = np.array([[3, -2, 17], [5, 1, 250], [0, 0, 1]], dtype=np.float32)
DIGEST = "00112233445566778899aabbccddeeff"


def craft(kind: int, payload: bytes, *, frame: int = 1, session: str = SESSION, flags=None,
          key: bytes | None = None, magic: bytes = b"CVSM", version: int = VERSION,
          length: int | None = None) -> bytes:
    """A message built by hand from the layout; signed when a key is given."""
    flags = (1 if key else 0) if flags is None else flags
    data = HEADER.pack(magic, version, kind, flags, 0, session_id(session), frame,
                       len(payload) if length is None else length) + payload
    return data + hmac.new(key, data, hashlib.sha256).digest() if key else data


def frame_body(dt_bits: int = 0x3C888889, matrix=IDENTITY, position=(0.0, 0.0, 0.0),
               orientation=(0.0, 0.0, 0.0, 1.0), buttons: int = 0, axes=(0.0,) * 4,
               params=(), count: int | None = None, head_position=(0.0, 0.0, 1.7),
               head_orientation=(0.0, 0.0, 0.0, 1.0)) -> bytes:
    """A frame payload; `count` may disagree with the parameters that follow."""
    count = len(params) if count is None else count
    return FRAME_BODY.pack(dt_bits, *np.asarray(matrix, np.float32).ravel().tolist(),
                           *head_position, *head_orientation, *position, *orientation,
                           buttons, *axes, count) + \
        struct.pack(f"<{len(params)}f", *params)


def name(text: bytes) -> bytes:
    return bytes([len(text)]) + text


def snapshot_body(particles: int = 3, emitters: int = 0, chunk: int = 2) -> bytes:
    """A snapshot header's payload; `emitters` is only the count (no records follow)."""
    return struct.pack("<QIII16s", 9, particles, emitters, chunk, bytes.fromhex(DIGEST))


def report_body(node: bytes = b"front", status: int = 0, extra: bytes = b"") -> bytes:
    return name(node) + struct.pack("<16sIIIIIB", bytes.fromhex(DIGEST), 1, 2, 3, 4, 5,
                                    status) + extra


def info_body(node: bytes = b"front", device: int = 0, software: int = 1,
              texts=(b"llvmpipe", b"Mesa", b"4.5 Mesa"), extra: bytes = b"") -> bytes:
    return name(node) + struct.pack("<HB", device, software) + b"".join(map(name, texts)) + extra


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


def reason_of(data: bytes, session: str = SESSION, key: bytes | None = None) -> str:
    with pytest.raises(ProtocolError) as error:
        decode(data, session, key)
    return error.value.reason


# -- round trips ---------------------------------------------------------------------------

EDGE_MESSAGES = {
    "frame": FrameMessage(1, FrameInput(1 / 60, MATRIX)),
    "frame-max-params": FrameMessage(U64, FrameInput(0.0, IDENTITY), WandState(
        (1.5, -2.0, 3e38), (0.0, 0.0, -0.0, 1.0), 2**32 - 1, (-1.0, 1.0, 0.5, 1e-45)),
        tuple(float(i) - 0.5 for i in range(MAX_PARAMS))),
    "frame-zero": FrameMessage(0, FrameInput(-0.0, IDENTITY)),
    "report": ReportMessage(7, "front", DIGEST, 1490, 1, 120, 35, 3, Status.STEPPED),
    "report-edges": ReportMessage(U64, "x" * 32, "f" * 32, 2**32 - 1, 0, 0, 2**32 - 1,
                                  2**32 - 1, Status.REPEATED),
    "report-resynced": ReportMessage(2, "wall_7-b", "0" * 32, 0, 0, 0, 0, 0, Status.RESYNCED),
    "stop": ControlMessage(400, Command.STOP),
    "resync": ControlMessage(U64, Command.RESYNC, "left", "front"),
    "resync-long-names": ControlMessage(3, Command.RESYNC, "a" * 32, "B-_9" * 8),
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
    "info": InfoMessage(3, "front", 0, True, "llvmpipe (LLVM 15.0.6, 256 bits)", "Mesa/X.org",
                        "4.5 (Core Profile) Mesa 22.3.6"),
    "info-edges": InfoMessage(U64, "x" * 32, 2**16 - 1, False, "~" * MAX_TEXT, "", " "),
}


@pytest.mark.parametrize("key", [None, KEY], ids=["unsigned", "signed"])
@pytest.mark.parametrize("message", EDGE_MESSAGES.values(), ids=EDGE_MESSAGES.keys())
def test_every_kind_round_trips_with_edge_values(message, key):
    data = encode(message, SESSION, key)
    assert len(data) == HEADER.size + HEADER.unpack_from(data)[-1] + (32 if key else 0)
    decoded = decode(data, SESSION, key)
    assert comparable(decoded) == comparable(message)
    assert encode(decoded, SESSION, key) == data


@given(message=messages(), key=st.none() | hmac_keys)
def test_any_message_round_trips(message, key):
    decoded = decode(encode(message, SESSION, key), SESSION, key)
    assert comparable(decoded) == comparable(message)


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
    assert f32_bits(decode(encode(message, SESSION, KEY), SESSION, KEY).inputs.dt) == sent


def test_info_message_is_made_from_a_gpu_description_and_gives_it_back():
    gpu = {"device": 2, "kind": "hardware", "renderer": "NVIDIA H100\u2122 80GB",
           "vendor": "NVIDIA Corporation", "version": "4.6.0 NVIDIA 580.65" + "0" * 300}
    message = InfoMessage.of_gpu(7, "front", gpu)
    assert message.renderer == "NVIDIA H100? 80GB" and len(message.version) == MAX_TEXT
    assert decode(encode(message, SESSION, KEY), SESSION, KEY) == message
    assert message.gpu() == {**gpu, "renderer": message.renderer, "version": message.version}
    assert InfoMessage.of_gpu(0, "left", {**gpu, "kind": "software"}).gpu()["kind"] == "software"


def test_crafted_bytes_match_encode():
    """The layout these tests craft by hand is the one `encode` writes."""
    assert HEADER.size == 28
    stop = ControlMessage(9, Command.STOP)
    assert encode(stop, SESSION) == craft(Kind.CONTROL, b"\x02\x00\x00", frame=9)
    assert encode(stop, SESSION, KEY) == craft(Kind.CONTROL, b"\x02\x00\x00", frame=9, key=KEY)
    frame = FrameMessage(1, FrameInput(np.float32(1 / 60), MATRIX), params=(0.25,))
    assert encode(frame, SESSION) == craft(Kind.FRAME, frame_body(
        f32_bits(1 / 60), MATRIX, params=(0.25,)))
    info = InfoMessage(1, "front", 0, True, "llvmpipe", "Mesa", "4.5 Mesa")
    assert encode(info, SESSION) == craft(Kind.INFO, info_body())


@pytest.mark.parametrize("message, match", [
    (FrameMessage(1, FrameInput(0.0, IDENTITY), params=(0.0,) * (MAX_PARAMS + 1)),
     "at most 32"),
    (ReportMessage(1, "bad/name", DIGEST, 0, 0, 0, 0), "node name"),
    (ReportMessage(1, "", DIGEST, 0, 0, 0, 0), "node name"),
    (ControlMessage(1, Command.RESYNC, "x" * 33, "front"), "node name"),
    (InfoMessage(1, "front", 2**16, False, "r", "v", "4.6"), "device index"),
    (InfoMessage(1, "front", 0, False, "r" * (MAX_TEXT + 1), "v", "4.6"), "renderer"),
    (InfoMessage(1, "front", 0, False, "r", "v\u00e9", "4.6"), "vendor"),
    (InfoMessage(1, "front", 0, False, "r", "v", "4.6\n"), "version"),
    (InfoMessage(1, "", 0, False, "r", "v", "4.6"), "node name"),
    (SnapshotHeader(1, 0, 10, 0, DIGEST, np.zeros(0, EMITTER_DTYPE)), "chunks of 1 to"),
    (SnapshotHeader(1, 0, MAX_PARTICLES + 1, 1, DIGEST, np.zeros(0, EMITTER_DTYPE)),
     "at most"),
    (SnapshotHeader(1, 0, 1, 1, "XY" * 16, np.zeros(0, EMITTER_DTYPE)), "hex digits"),
    (SnapshotChunk(1, 0, bytes(41)), "whole 40-byte records"),
    (SnapshotChunk(1, 0, b""), "whole 40-byte records"),
])
def test_encode_refuses_what_decode_would_reject(message, match):
    with pytest.raises(ValueError, match=match):
        encode(message, SESSION)


# -- every rejection -----------------------------------------------------------------------

STOP = craft(Kind.CONTROL, b"\x02\x00\x00")
SIGNED_STOP = craft(Kind.CONTROL, b"\x02\x00\x00", key=KEY)
SIGNED_FRAME = encode(EDGE_MESSAGES["frame-max-params"], SESSION, KEY)
NAN32 = 0x7FC00000

REJECTIONS = [
    # (id, bytes, decoding key, reason)
    ("empty", b"", None, "truncated"),
    ("header-minus-one", STOP[:27], None, "truncated"),
    ("magic-only", b"CVSM", KEY, "truncated"),
    ("magic", b"CVSN" + STOP[4:], None, "bad-magic"),
    ("magic-lowercase", b"cvsm" + STOP[4:], KEY, "bad-magic"),
    ("version-0", craft(Kind.CONTROL, b"\x02\x00\x00", version=0), None, "bad-version"),
    ("version-next", craft(Kind.CONTROL, b"\x02\x00\x00", version=VERSION + 1), None,
     "bad-version"),
    ("kind-0", craft(0, b"\x02\x00\x00"), None, "bad-kind"),
    ("kind-next", craft(max(Kind) + 1, b"\x02\x00\x00"), None, "bad-kind"),
    ("kind-255", craft(255, b"\x02\x00\x00", key=KEY), KEY, "bad-kind"),
    ("other-session", craft(Kind.CONTROL, b"\x02\x00\x00", session="other"), None,
     "wrong-session"),
    ("other-session-signed", craft(Kind.CONTROL, b"\x02\x00\x00", session="other", key=KEY),
     KEY, "wrong-session"),
    ("flag-2", craft(Kind.CONTROL, b"\x02\x00\x00", flags=0x02), None, "bad-flags"),
    ("flag-signed-and-128", craft(Kind.CONTROL, b"\x02\x00\x00", flags=0x81, key=KEY), KEY,
     "bad-flags"),
    ("one-byte-short", STOP[:-1], None, "bad-length"),
    ("one-byte-long", STOP + b"\x00", None, "bad-length"),
    ("length-oversized", craft(Kind.CONTROL, b"\x02\x00\x00", length=2**32 - 1), None,
     "bad-length"),
    ("length-zero", craft(Kind.CONTROL, b"\x02\x00\x00", length=0), None, "bad-length"),
    ("signature-cut-short", SIGNED_STOP[:-1], KEY, "bad-length"),
    ("signature-missing", SIGNED_STOP[:-32], KEY, "bad-length"),
    ("signature-flag-cleared", SIGNED_STOP[:6] + b"\x00" + SIGNED_STOP[7:], KEY, "bad-length"),
    ("unsigned", STOP, KEY, "unsigned"),
    ("unsigned-frame", encode(EDGE_MESSAGES["frame"], SESSION), KEY, "unsigned"),
    ("wrong-key", craft(Kind.CONTROL, b"\x02\x00\x00", key=OTHER_KEY), KEY, "bad-signature"),
    ("flipped-payload-bit", SIGNED_STOP[:28] + b"\x03" + SIGNED_STOP[29:], KEY,
     "bad-signature"),
    ("flipped-frame-bit", SIGNED_STOP[:16] + b"\x00" + SIGNED_STOP[17:], KEY, "bad-signature"),
    ("flipped-signature-bit", SIGNED_STOP[:-1] + bytes([SIGNED_STOP[-1] ^ 0x80]), KEY,
     "bad-signature"),
    ("unexpected-signature", SIGNED_STOP, None, "unexpected-signature"),
    # payloads
    ("frame-too-short", craft(Kind.FRAME, frame_body()[:-1]), None, "bad-payload"),
    ("frame-count-above-params", craft(Kind.FRAME, frame_body(params=(1.0, 2.0), count=3)),
     None, "bad-payload"),
    ("frame-count-below-params", craft(Kind.FRAME, frame_body(params=(1.0, 2.0), count=1)),
     None, "bad-payload"),
    ("frame-33-params", craft(Kind.FRAME, frame_body(params=(0.0,) * 33)), None,
     "bad-payload"),
    ("frame-signed-count-mismatch", craft(Kind.FRAME, frame_body(params=(1.0,), count=0),
                                          key=KEY), KEY, "bad-payload"),
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
    ("control-empty", craft(Kind.CONTROL, b""), None, "bad-payload"),
    ("control-command-0", craft(Kind.CONTROL, b"\x00\x00\x00"), None, "bad-payload"),
    ("control-command-4", craft(Kind.CONTROL, b"\x04\x00\x00"), None, "bad-payload"),
    ("control-stray-bytes", craft(Kind.CONTROL, b"\x02\x00\x00\x00"), None, "bad-payload"),
    ("control-source-missing", craft(Kind.CONTROL, b"\x01" + name(b"left")), None,
     "bad-payload"),
    ("control-target-tab", craft(Kind.CONTROL, b"\x01" + name(b"le\tft") + name(b"front")),
     None, "bad-payload"),
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
    ("param-nan", craft(Kind.FRAME, frame_body(params=(1.0, math.nan))), None, "bad-value"),
    ("param-signed-inf", craft(Kind.FRAME, frame_body(params=(-math.inf,)), key=KEY), KEY,
     "bad-value"),
    ("report-status-3", craft(Kind.REPORT, report_body(status=3)), None, "bad-value"),
    ("info-empty", craft(Kind.INFO, b""), None, "bad-payload"),
    ("info-name-slash", craft(Kind.INFO, info_body(node=b"a/b")), None, "bad-payload"),
    ("info-body-short", craft(Kind.INFO, name(b"front") + b"\x00\x00"), None, "bad-payload"),
    ("info-string-missing", craft(Kind.INFO, info_body(texts=(b"r", b"v"))), None,
     "bad-payload"),
    ("info-string-past-end", craft(Kind.INFO, info_body()[:-1]), None, "bad-payload"),
    ("info-stray-byte", craft(Kind.INFO, info_body(extra=b"\x00")), None, "bad-payload"),
    ("info-flag-4", craft(Kind.INFO, info_body(software=4)), None, "bad-value"),
    ("display-phase-3", craft(Kind.DISPLAY, name(b"front") + bytes([3]) + bytes(8)), None,
     "bad-value"),
    ("display-short", craft(Kind.DISPLAY, name(b"front") + bytes([1]) + bytes(7)), None,
     "bad-payload"),
    ("info-string-control", craft(Kind.INFO, info_body(texts=(b"r\n", b"v", b"4"))), None,
     "bad-value"),
    ("info-string-utf8", craft(Kind.INFO, info_body(texts=(b"r", "v\u00e9".encode(), b"4"))),
     None, "bad-value"),
    ("info-string-del", craft(Kind.INFO, info_body(texts=(b"r", b"v", b"\x7f"))), None,
     "bad-value"),
]


@pytest.mark.parametrize("data, key, reason", [case[1:] for case in REJECTIONS],
                         ids=[case[0] for case in REJECTIONS])
def test_each_crafted_input_is_rejected_for_its_reason(data, key, reason):
    assert reason_of(data, SESSION, key) == reason


def test_every_reason_decode_raises_has_a_crafted_case():
    """A new ProtocolError reason in messages.py needs a case in REJECTIONS."""
    source = Path(wire.__file__).read_text()
    raised = set(re.findall(r'ProtocolError\(\s*"([a-z-]+)"', source))
    assert raised == {case[3] for case in REJECTIONS}


def flip_reason(index: int, bit: int) -> str:
    """Why a signed STOP with bit `bit` of byte `index` flipped must be rejected."""
    if index < 4:
        return "bad-magic"
    if index == 4:
        return "bad-version"
    if index == 5:  # CONTROL (3) may turn into another known kind, which the HMAC catches
        return "bad-signature" if Kind.CONTROL ^ (1 << bit) in set(Kind) else "bad-kind"
    if index == 6:  # without the signed flag the attached HMAC is 32 bytes too many
        return "bad-length" if bit == 0 else "bad-flags"
    if index == 7:  # the reserved byte must stay 0
        return "bad-flags"
    if 8 <= index < 16:
        return "wrong-session"
    if 24 <= index < 28:
        return "bad-length"
    return "bad-signature"  # the frame number, the payload and the HMAC


@pytest.mark.parametrize("index", range(len(SIGNED_STOP)))
def test_one_flipped_bit_anywhere_in_a_signed_message_is_rejected(index):
    for bit in range(8):
        flipped = bytearray(SIGNED_STOP)
        flipped[index] ^= 1 << bit
        assert reason_of(bytes(flipped), SESSION, KEY) == flip_reason(index, bit), bit


@pytest.mark.parametrize("index", range(0, len(SIGNED_FRAME), 7))
def test_flipped_bits_of_a_signed_frame_are_rejected(index):
    for bit in (0, 3, 7):
        flipped = bytearray(SIGNED_FRAME)
        flipped[index] ^= 1 << bit
        with pytest.raises(ProtocolError):
            decode(bytes(flipped), SESSION, KEY)


# -- fuzzing -------------------------------------------------------------------------------

def decodes_or_rejects(data: bytes, session: str = SESSION, key: bytes | None = None):
    """decode's only outcomes: a message or ProtocolError (any other exception fails)."""
    try:
        return decode(data, session, key)
    except ProtocolError as e:
        assert e.reason and str(e).startswith(e.reason)
        return None


@given(data=st.binary(max_size=600), key=st.none() | st.just(KEY))
def test_decode_of_arbitrary_bytes_returns_or_raises_protocol_error(data, key):
    decodes_or_rejects(data, SESSION, key)


@st.composite
def behind_a_valid_header(draw) -> bytes:
    """Arbitrary payloads under a header that passes, so the payload readers get fuzzed."""
    kind = draw(st.sampled_from(Kind))
    payload = draw(st.binary(max_size=600))
    return craft(kind, payload, frame=draw(st.integers(0, U64)))


@given(data=behind_a_valid_header())
def test_decode_of_arbitrary_payloads_returns_or_raises_protocol_error(data):
    decodes_or_rejects(data)


@given(message=messages(), changes=st.lists(mutations, min_size=1, max_size=4))
@example(message=EDGE_MESSAGES["stop"], changes=[Mutation("flip", 7.5 / 31, 0xFF)])
def test_decode_of_mutated_messages_returns_or_raises_protocol_error(message, changes):
    data = mutate(encode(message, SESSION), changes)
    decoded = decodes_or_rejects(data)
    if decoded is not None:
        # Whatever passes is canonical: it encodes to the same bytes, so the frame log and
        # every node see one meaning (the reserved byte 7 must be 0).
        assert encode(decoded, SESSION) == data
    decodes_or_rejects(mutate(encode(message, SESSION, KEY), changes), SESSION, None)


@given(message=messages(), change=mutations)
def test_any_mutation_of_a_signed_message_is_rejected(message, change):
    data = change.apply(encode(message, SESSION, KEY))
    with pytest.raises(ProtocolError):
        decode(data, SESSION, KEY)


@given(message=messages(), key=hmac_keys, other=hmac_keys)
def test_a_wrong_key_is_rejected(message, key, other):
    # HMAC pads a key shorter than its block with zero bytes: keys that differ only in
    # trailing zeros are the same key
    assume(key.rstrip(b"\0") != other.rstrip(b"\0"))
    assert reason_of(encode(message, SESSION, other), SESSION, key) == "bad-signature"


@given(message=messages(), mine=names, theirs=names, key=st.none() | hmac_keys)
def test_sessions_never_decode_each_others_messages(message, mine, theirs, key):
    assume(mine != theirs)
    assert reason_of(encode(message, theirs, key), mine, key) == "wrong-session"


@given(message=frame_messages | report_messages | control_messages | snapshot_messages
       | info_messages)
def test_a_signed_message_is_unexpected_without_key_and_unsigned_with_one(message):
    assert reason_of(encode(message, SESSION, KEY), SESSION) == "unexpected-signature"
    assert reason_of(encode(message, SESSION), SESSION, KEY) == "unsigned"
