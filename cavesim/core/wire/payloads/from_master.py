"""What only the master sends, under its own signature: a frame's inputs, a command
(resync, stop, swap, welcome), and its question to a node about its GPU.

A frame's fields are written and read by one codec that speaks a named `FrameLayout`: the
wire speaks `WIRE_FRAME`, and the frame log (`cavesim.core.framelog`) names layouts of its
own, so that the wire's frame can move on without changing what a log writes or reads."""

from __future__ import annotations

import math
import secrets
import struct
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from cavesim.core.errors import ProtocolError
from cavesim.core.frame import FrameInput
from cavesim.core.scene.model import Engine
from cavesim.core.wire.payloads._fields import digest_bytes, name_bytes, read_name
from cavesim.core.wire.payloads.poses import HeadState, WandState

MAX_PARAMS = 32
_FIELDS = struct.Struct("<I9f3f4f3f4fI4fH")  # dt bits, matrix, head, wand, buttons, axes, n
# then n float32 parameters, then (in a layout with events) one byte of the frame's events:
RESET = 0x01  # every node goes back to the scene's start state before it steps this frame
_CONTROL_TAIL = struct.Struct("<16sQB")  # a digest (RESYNC, WELCOME), nonce and engine
# (WELCOME)
_ENGINE_CODES = {None: 0, Engine.GS_TF: 1, Engine.COMPUTE: 2}  # a WELCOME's engine byte
_ENGINES = {code: engine for engine, code in _ENGINE_CODES.items()}
_INFO_NONCE = struct.Struct("<Q")  # an info request's own nonce, after the node's name


class Command(IntEnum):
    RESYNC = 1  # target loads `source`'s state of the frame, whose checksum is `digest`,
    # confirmed by `confirmer` (none: no second wall holds it)
    STOP = 2  # every node ends cleanly
    SWAP = 3  # every swap-locked wall has drawn the frame: show it
    WELCOME = 4  # target joins this run (the header's run id) of the scene `digest` names;
    # `nonce` is its own, fresh; `engine`: the path a node of `engine = "auto"` steps with


@dataclass(frozen=True)
class FrameMessage:
    frame: int
    inputs: FrameInput
    wand: WandState = WandState()
    params: tuple[float, ...] = ()  # the scene's time-varying parameters
    head: HeadState = HeadState()  # tracked or scripted, sampled once by the master
    reset: bool = False  # the state goes back to the scene's start before this frame's step


@dataclass(frozen=True)
class FrameLayout:
    """A named byte layout of a frame message's fields, all but its number (which the wire
    carries in its header and a frame log in its record): dt as float32 bits, the
    random-texture matrix, head, wand, buttons, axes, the parameter count and the
    parameters, then, `events` or not, a byte of the frame's events.

    Whoever writes frames names the layout it speaks, and reads only its own: the wire
    `WIRE_FRAME`, the frame log each of its versions' (`cavesim.core.framelog`). A change of
    the wire's frame is a new option here (a field without a default, so that every layout
    states it) that `WIRE_FRAME` takes up; every other layout, and so every log, keeps its
    bytes."""

    name: str  # what a reader's error calls it
    events: bool  # ends in a byte of events (RESET); frames of wire versions 4-10 did not


WIRE_FRAME = FrameLayout("frame payload", events=True)  # the wire's, since version 11


@dataclass(frozen=True)
class ControlMessage:
    frame: int
    command: Command
    target: str = ""
    source: str = ""
    digest: str = ""  # RESYNC: the state to load's checksum; WELCOME: the scene's digest
    nonce: int = 0  # WELCOME: the nonce the target last sent in its info
    engine: Engine | None = None  # WELCOME of a node that probed its path: the run's path
    confirmer: str = ""  # RESYNC: the second wall holding the state, which confirms it


@dataclass(frozen=True)
class InfoRequest:
    """The master's question to a node: which GPU do you compute on, and your nonce? Its
    own `nonce` is fresh: a node takes each once (a replayed question is refused)."""

    frame: int
    node: str
    nonce: int = field(default_factory=lambda: secrets.randbits(64))


def write_frame(m: FrameMessage) -> bytes:
    return write_frame_fields(WIRE_FRAME, m)


def read_frame(frame: int, payload: bytes) -> FrameMessage:
    return read_frame_fields(WIRE_FRAME, frame, payload)


def write_frame_fields(layout: FrameLayout, m: FrameMessage) -> bytes:
    """`m`'s fields (not its number) in `layout`; ValueError if they do not fit it."""
    if len(m.params) > MAX_PARAMS:
        raise ValueError(f"at most {MAX_PARAMS} scene parameters, got {len(m.params)}")
    if m.reset and not layout.events:
        raise ValueError(f"a {layout.name} has no events byte: it cannot carry a reset")
    w, h = m.wand, m.head
    values = np.array([*h.position, *h.orientation, *w.position, *w.orientation, *w.axes,
                       *m.params], dtype=np.float64)
    if not np.all(np.isfinite(values)) or np.any(np.abs(values) > np.finfo(np.float32).max):
        raise ValueError(f"head, wand and scene parameters must be finite float32 values, "
                         f"got {h}, {w} and {m.params}")
    dt_bits = int(np.float32(m.inputs.dt).view(np.uint32))
    body = _FIELDS.pack(dt_bits, *m.inputs.random_transform.ravel().tolist(), *h.position,
                        *h.orientation, *w.position, *w.orientation, w.buttons, *w.axes,
                        len(m.params))
    events = bytes([RESET * m.reset]) if layout.events else b""
    return body + np.asarray(m.params, dtype="<f4").tobytes() + events


def read_frame_fields(layout: FrameLayout, frame: int, data: bytes) -> FrameMessage:
    """The frame message numbered `frame` whose fields `data` holds in `layout`, all of
    `data`; ProtocolError names what is wrong."""
    if len(data) < _FIELDS.size:
        raise ProtocolError("bad-payload", f"{layout.name} of {len(data)} bytes is too short "
                                           f"(at least {_FIELDS.size})")
    values = _FIELDS.unpack_from(data)
    count, tail = values[-1], 1 if layout.events else 0
    if count > MAX_PARAMS or len(data) != _FIELDS.size + 4 * count + tail:
        then = ", then one byte of events" if layout.events else ""
        raise ProtocolError("bad-payload", f"{layout.name} announces {count} parameters in "
                                           f"{len(data)} bytes (at most {MAX_PARAMS}{then})")
    events = data[-1] if layout.events else 0
    if events & ~RESET:
        raise ProtocolError("bad-value", f"frame events {events:#04x}: only {RESET:#04x} "
                                         f"(reset) is defined")
    dt = np.array([values[0]], dtype=np.uint32).view(np.float32)[0]
    matrix = np.array(values[1:10], dtype=np.float32).reshape(3, 3)
    head, wand, buttons, axes = values[10:17], values[17:24], values[24], values[25:29]
    params = np.frombuffer(data, dtype="<f4", offset=_FIELDS.size, count=count)
    if not all(math.isfinite(v) for v in (*head, *wand, *axes, *params.tolist())):
        raise ProtocolError("bad-value", "head, wand and scene parameters must be finite")
    try:
        inputs = FrameInput(dt, matrix)
    except ValueError as e:
        raise ProtocolError("bad-value", str(e)) from e
    return FrameMessage(frame, inputs, WandState(wand[:3], wand[3:], buttons, axes),
                        tuple(params.tolist()), HeadState(head[:3], head[3:]),
                        bool(events & RESET))


def write_control(m: ControlMessage) -> bytes:
    digest = digest_bytes(m.digest) if m.digest else bytes(16)
    if m.digest and not any(digest):
        raise ValueError("a control message cannot name the all-zero digest (it means none)")
    if not 0 <= m.nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {m.nonce}")
    return bytes([m.command]) + b"".join(name_bytes(name, True) for name in (
        m.target, m.source, m.confirmer)) + _CONTROL_TAIL.pack(digest, m.nonce,
                                                               _ENGINE_CODES[m.engine])


def read_control(frame: int, payload: bytes) -> ControlMessage:
    if not payload or payload[0] not in Command.__members__.values():
        raise ProtocolError("bad-payload", "control message without a known command")
    target, rest = read_name(payload[1:], optional=True)
    source, rest = read_name(rest, optional=True)
    confirmer, rest = read_name(rest, optional=True)
    if len(rest) != _CONTROL_TAIL.size:
        raise ProtocolError("bad-payload", f"control message ends in {len(rest)} bytes, "
                                           f"expected {_CONTROL_TAIL.size}")
    digest, nonce, engine = _CONTROL_TAIL.unpack(rest)
    if engine not in _ENGINES:
        raise ProtocolError("bad-value", f"control message names engine {engine}: only "
                                         f"{', '.join(map(str, _ENGINES))} are defined")
    return ControlMessage(frame, Command(payload[0]), target, source,
                          digest.hex() if any(digest) else "", nonce, _ENGINES[engine],
                          confirmer)


def write_info_request(m: InfoRequest) -> bytes:
    if not 0 <= m.nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {m.nonce}")
    return name_bytes(m.node) + _INFO_NONCE.pack(m.nonce)


def read_info_request(frame: int, payload: bytes) -> InfoRequest:
    node, rest = read_name(payload)
    if len(rest) != _INFO_NONCE.size:
        raise ProtocolError("bad-payload", f"an info request ends in {len(rest)} bytes, "
                                           f"expected its {_INFO_NONCE.size}-byte nonce")
    (nonce,) = _INFO_NONCE.unpack(rest)
    return InfoRequest(frame, node, nonce)
