"""ART DTrack2's ASCII output, one UDP datagram per measurement, parsed without trust.

A datagram is lines separated by CRLF, each a type and its values (DTrack2 manual,
"Output data"; ids count from 0, while DTrack2's own windows count from 1):

    fr 21753                                       frame counter
    ts 39596.024831                                timestamp, s since midnight
    6d N [id qu][sx sy sz eta theta phi][b0 ... b8] ... N standard bodies
    6df2 DEF N [id qu nbt nct][sx sy sz][b0 ... b8][bt ... ct ...] ... N of DEF Flysticks

Positions are millimetres in DTrack's room; b0 ... b8 the rotation body → room, column by
column (the Euler angles are skipped). A quality below 0 means "not tracked": the pose is
then no pose (DTrack sends zeros), but a Flystick's buttons and joystick still count. A
Flystick sends ceil(nbt / 32) button words (bit i of word k: button 32k + i) and nct
controllers in [-1, 1]. Other lines (6dcal, 3d, 6df, 6dmt, gl, ...) are skipped.

`parse_datagram` checks every value and raises ProtocolError with a short reason to count;
it never returns a half-checked datagram.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from cavesim.core.errors import ProtocolError
from cavesim.core.tracking.rotation import is_rotation

MAX_DATAGRAM = 32768  # bytes: a CAVE's few bodies take well under 2 KiB
MAX_POSITION_MM = 1e6  # 1 km from DTrack's origin: farther is a fault, not a room
ROTATION_TOLERANCE = 0.01  # DTrack2 may print matrices with only 3 decimals
BUTTONS_PER_WORD = 32
KNOWN = ("fr", "ts", "6d", "6df2")

_LINE_TYPE = re.compile(r"[0-9a-z]+")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_WHOLE = re.compile(r"\d{1,10}")


@dataclass(frozen=True)
class Body:
    """A 6d body, or a Flystick's pose, as DTrack sends it."""

    id: int
    quality: float  # 0 to 1 when tracked, negative when not
    position: tuple[float, float, float]  # mm in DTrack's room
    rotation: tuple[tuple[float, float, float], ...]  # rows of the 3×3 matrix body → room

    @property
    def tracked(self) -> bool:
        return self.quality >= 0


@dataclass(frozen=True)
class Flystick(Body):
    """A 6df2 Flystick: a pose, its buttons (bit i: button i, the first 32) and controllers."""

    buttons: int
    controllers: tuple[float, ...]  # joystick axes, each in [-1, 1]


@dataclass(frozen=True)
class Datagram:
    """One checked DTrack datagram: the bodies and Flysticks it reports, by id."""

    frame: int | None  # `fr`, when DTrack sends it
    timestamp: float | None  # `ts`, when DTrack sends it
    bodies: Mapping[int, Body]
    flysticks: Mapping[int, Flystick]


def parse_datagram(data: bytes) -> Datagram:
    """Check and parse one datagram; ProtocolError names what is wrong."""
    if len(data) > MAX_DATAGRAM:
        raise ProtocolError("too-large", f"{len(data)} bytes, at most {MAX_DATAGRAM}")
    try:
        text = bytes(data).decode("ascii")
    except UnicodeDecodeError as e:
        raise ProtocolError("not-ascii", f"byte {data[e.start]:#04x} at offset {e.start}; "
                                         f"DTrack's output is ASCII text") from e
    lines: dict[str, str] = {}
    for line in re.split(r"\r?\n", text.rstrip("\0")):  # some senders end with a C string's NUL
        kind, _, rest = line.strip().partition(" ")
        if not kind:
            continue
        if not _LINE_TYPE.fullmatch(kind):
            raise ProtocolError("bad-line", f"a line starts with {kind[:20]!r}, not a line type")
        if kind in lines:
            raise ProtocolError("bad-line", f"a second {kind!r} line")
        lines[kind] = rest
    if not lines.keys() & set(KNOWN):
        raise ProtocolError("no-data", f"none of the lines {', '.join(KNOWN)}")
    frame = _whole(lines["fr"].strip(), "fr") if "fr" in lines else None
    timestamp = _timestamp(lines["ts"]) if "ts" in lines else None
    bodies = _bodies(lines.get("6d", "0"))
    flysticks = _flysticks(lines.get("6df2", "0 0"))
    return Datagram(frame, timestamp, bodies, flysticks)


def _timestamp(text: str) -> float:
    values = _numbers(text, "ts")
    if len(values) != 1 or values[0] < 0:
        raise ProtocolError("bad-value", f"ts {text[:40]!r} is not one time >= 0")
    return values[0]


def _bodies(text: str) -> dict[int, Body]:
    (count,), blocks = _counts_and_blocks(text, 1, "6d")
    if len(blocks) != 3 * count:
        raise ProtocolError("bad-count", f"6d announces {count} bodies in {len(blocks)} "
                                         f"blocks, 3 per body")
    bodies: dict[int, Body] = {}
    for i in range(0, len(blocks), 3):
        head = blocks[i].split()
        if len(head) != 2:
            raise ProtocolError("bad-count", f"6d [{blocks[i][:40]}] is not [id quality]")
        body = _body(_whole(head[0], "6d id"), head[1], blocks[i + 1], 6, blocks[i + 2], "6d")
        _add(bodies, body, "6d")
    return bodies


def _flysticks(text: str) -> dict[int, Flystick]:
    (defined, count), blocks = _counts_and_blocks(text, 2, "6df2")
    if len(blocks) != 4 * count or count > defined:
        raise ProtocolError("bad-count", f"6df2 announces {count} of {defined} Flysticks in "
                                         f"{len(blocks)} blocks, 4 per Flystick")
    flysticks: dict[int, Flystick] = {}
    for i in range(0, len(blocks), 4):
        head = blocks[i].split()
        if len(head) != 4:
            raise ProtocolError("bad-count", f"6df2 [{blocks[i][:40]}] is not [id quality "
                                             f"buttons controllers]")
        id_, n_buttons, n_controllers = (_whole(head[k], "6df2 " + what)
                                         for k, what in ((0, "id"), (2, "nbt"), (3, "nct")))
        where = f"6df2 Flystick {id_}"
        body = _body(id_, head[1], blocks[i + 1], 3, blocks[i + 2], where)
        buttons, controllers = _inputs(blocks[i + 3], n_buttons, n_controllers, where)
        _add(flysticks, Flystick(body.id, body.quality, body.position, body.rotation, buttons,
                                 controllers), "6df2")
    return flysticks


def _body(id_: int, quality: str, pose: str, pose_values: int, matrix: str, where: str) -> Body:
    """A checked pose: [quality], [sx sy sz ...] (`pose_values` numbers), [b0 ... b8]."""
    (q,) = _numbers(quality, where)
    values, b = _numbers(pose, where), _numbers(matrix, where)
    if len(values) != pose_values or len(b) != 9:
        raise ProtocolError("bad-count", f"{where} {id_}: {len(values)} pose values and {len(b)} "
                                         f"matrix entries, expected {pose_values} and 9")
    if q > 1:
        raise ProtocolError("bad-value", f"{where} {id_}: quality {q} is above 1")
    position = tuple(values[:3])
    if any(abs(x) > MAX_POSITION_MM for x in position):
        raise ProtocolError("bad-value", f"{where} {id_}: position {position} mm is beyond "
                                         f"±{MAX_POSITION_MM:g} mm")
    rotation = np.array(b).reshape(3, 3).T  # DTrack writes it column by column
    if q >= 0 and not is_rotation(rotation, ROTATION_TOLERANCE):
        raise ProtocolError("bad-rotation", f"{where} {id_}: {b} is not a rotation matrix "
                                            f"(orthonormal within {ROTATION_TOLERANCE}, det > 0)")
    return Body(id_, q, position, tuple(tuple(row) for row in rotation.tolist()))


def _inputs(text: str, n_buttons: int, n_controllers: int,
            where: str) -> tuple[int, tuple[float, ...]]:
    """The first 32 buttons as a bitmask and the controllers of a Flystick's last block."""
    words = -(-n_buttons // BUTTONS_PER_WORD)
    values = text.split()
    if len(values) != words + n_controllers:
        raise ProtocolError("bad-count", f"{where}: {len(values)} button words and controllers, "
                                         f"{n_buttons} buttons and {n_controllers} controllers "
                                         f"need {words + n_controllers}")
    bits = [_whole(w, where + " buttons") for w in values[:words]]
    unused = BUTTONS_PER_WORD * words - n_buttons
    if any(w >= 2**BUTTONS_PER_WORD for w in bits) or (bits and bits[-1] >> (32 - unused)):
        raise ProtocolError("bad-value", f"{where}: button words {bits} set bits beyond its "
                                         f"{n_buttons} buttons")
    controllers = tuple(_numbers(" ".join(values[words:]), where))
    if any(abs(c) > 1 for c in controllers):
        raise ProtocolError("bad-value", f"{where}: controllers {controllers} must be in [-1, 1]")
    return (bits[0] if bits else 0), controllers


def _counts_and_blocks(text: str, counts: int, where: str) -> tuple[list[int], list[str]]:
    """The whole numbers before the first '[' and the contents of the [...] blocks after."""
    head, bracket, rest = text.partition("[")
    words = head.split()
    if len(words) != counts:
        raise ProtocolError("bad-count", f"{where} starts with {head.strip()[:40]!r}, expected "
                                         f"{counts} count(s)")
    blocks, rest = [], bracket + rest
    while rest:
        end = rest.find("]")
        if not rest.startswith("[") or end < 0 or "[" in rest[1:end]:
            raise ProtocolError("bad-line", f"{where}: {rest[:40]!r} is not a [...] block")
        blocks.append(rest[1:end])
        rest = rest[end + 1:].lstrip()
    return [_whole(w, where + " count") for w in words], blocks


def _add(found: dict, body: Body, where: str) -> None:
    if body.id in found:
        raise ProtocolError("bad-value", f"{where} reports id {body.id} twice")
    found[body.id] = body


def _whole(word: str, where: str) -> int:
    if not _WHOLE.fullmatch(word):
        raise ProtocolError("bad-number", f"{where} {word[:20]!r} is not a whole number >= 0")
    return int(word)


def _numbers(text: str, where: str) -> list[float]:
    values = []
    for word in text.split():
        if not _NUMBER.fullmatch(word):
            raise ProtocolError("bad-number", f"{where}: {word[:20]!r} is not a number")
        x = float(word)
        if not math.isfinite(x):
            raise ProtocolError("non-finite", f"{where}: {word[:20]!r} is beyond any float")
        values.append(x)
    return values
