"""The tracked head and wand: their states, which every frame carries, and the tracking
message a tracker (or a script, or a keyboard bridge) sends the master: stamped with its
sender's wall clock, so that the master can refuse an old one and a replayed one. The
preview window's message also carries its session controls (pause, reset, quit), and has no
pose until someone flies (the scene's script plays until then)."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from cavesim.core.errors import ProtocolError

TRACKING = struct.Struct("<3f4f3f4fI4fQBI")  # head, wand pose, buttons, axes, sent_ns,
# flags, resets asked
POSED, CONTROLS, PAUSED, QUIT = 0x01, 0x02, 0x04, 0x08  # the flags
MAX_TRACKING_AGE = 2.0  # s: the master ignores a tracking message sent longer ago (or ahead)


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
class SessionControls:
    """What the preview's user asks of the run: levels, so that the latest message says
    all (a lost one costs nothing)."""

    paused: bool = False
    resets: int = 0  # resets asked since the sender started: one more is one more reset
    quit: bool = False


@dataclass(frozen=True)
class TrackingMessage:
    """A tracker's (or a script's, or a keyboard bridge's) latest head and wand state."""

    frame: int  # the sender's own counter; the master ignores it
    head: HeadState
    wand: WandState
    sent_ns: int = 0  # the sender's wall clock (time.time_ns): its age, and its sequence
    # (the master takes from each sender only a message sent after the last it took)
    posed: bool = True  # head and wand are a pose (False: the preview before anyone flew)
    controls: SessionControls | None = None  # an operator's (the preview's); a tracker sends none


def write_tracking(m: TrackingMessage) -> bytes:
    h, w = m.head, m.wand
    values = np.array([*h.position, *h.orientation, *w.position, *w.orientation, *w.axes])
    if not np.all(np.isfinite(values)) or np.any(np.abs(values) > np.finfo(np.float32).max):
        raise ValueError(f"tracking values must be finite float32 values, got {h} and {w}")
    if not 0 <= m.sent_ns < 2**64:
        raise ValueError(f"sent_ns must be in [0, 2**64), got {m.sent_ns}")
    c = m.controls
    if c is not None and not 0 <= c.resets < 2**32:
        raise ValueError(f"resets must be in [0, 2**32), got {c.resets}")
    flags = POSED * m.posed | (0 if c is None else CONTROLS | PAUSED * c.paused | QUIT * c.quit)
    return TRACKING.pack(*h.position, *h.orientation, *w.position, *w.orientation, w.buttons,
                         *w.axes, m.sent_ns, flags, 0 if c is None else c.resets)


def read_tracking(frame: int, payload: bytes) -> TrackingMessage:
    if len(payload) != TRACKING.size:
        raise ProtocolError("bad-payload", f"tracking payload of {len(payload)} bytes, "
                                           f"expected {TRACKING.size}")
    v = TRACKING.unpack(payload)
    if not all(math.isfinite(x) for x in (*v[:14], *v[15:19])):
        raise ProtocolError("bad-value", "head and wand values must be finite")
    flags, resets = v[20:22]
    if flags & ~(POSED | CONTROLS | PAUSED | QUIT) or (
            not flags & CONTROLS and (flags & (PAUSED | QUIT) or resets)):
        raise ProtocolError("bad-value", f"tracking flags {flags:#04x} with {resets} resets: "
                                         f"pause, quit and resets come only with controls")
    controls = SessionControls(bool(flags & PAUSED), resets, bool(flags & QUIT)) \
        if flags & CONTROLS else None
    return TrackingMessage(frame, HeadState(v[0:3], v[3:7]), WandState(v[7:10], v[10:14], v[14],
                                                                         v[15:19]), v[19],
                           bool(flags & POSED), controls)
