"""What a wall node sends the master: its report of a frame (a fixed core, a tagged tail of
the frame's counters, and a drift sample in the mixed-hardware mode), its GPU when asked, and
its steps of the swap barrier.

A counter entry is its id (a row of cavesim/core/counters.py), its number of values and the
values: a counter a newer build adds is read here whatever its id (the master counts and
skips one it does not know), so a new counter moves no wire version. The reader is strict
about the tail's structure all the same: bounds, lengths, each id once."""

from __future__ import annotations

import struct
from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum

from cavesim.core.counters import BY_ID, MAX_ENTRIES, MAX_ID, MAX_VALUES
from cavesim.core.drift import MAX_SAMPLE, SAMPLE_DTYPE, DriftSample
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Engine
from cavesim.core.wire.payloads._fields import digest_bytes, name_bytes, read_name

MAX_TEXT = 255  # characters of one string of an info message (a one-byte length)
# The report's fixed core: digest, counts (live particles, emitters), each phase's
# microseconds (FRAME_PHASES), rejected, status
_REPORT = struct.Struct(f"<16sII{len(PHASES)}IIB")
# Then its counter tail: the entries that follow, and per entry the counter's id (its row in
# cavesim/core/counters.py) and how many uint values follow it
_COUNTERS = struct.Struct("<B")
_ENTRY = struct.Struct("<HB")
_SAMPLE = struct.Struct("<H")  # records of a report's drift sample, then the records
_INFO = struct.Struct("<HBQ16s")  # EGL device, flags, join nonce, scene; then three strings
INFO_SOFTWARE, INFO_SWAP_LOCKED, INFO_COMPUTE = 0x01, 0x02, 0x04  # COMPUTE: else GS/TF
INFO_AUTO = 0x08  # the node probed its engine path (`auto`) and steps with the run's
_DISPLAY = struct.Struct("<BQ")  # phase, the node's monotonic clock in ns


class Status(IntEnum):
    STEPPED = 0  # the node stepped this frame
    RESYNCED = 1  # the node loaded a snapshot of this frame
    REPEATED = 2  # a repeat of an earlier report (the frame came again)
    JOINED = 3  # the node took the run's WELCOME: it holds the scene's start state
    BEHIND = 4  # the node holds `frame`, older than the cluster's: it asks for a resync


@dataclass(frozen=True)
class ReportMessage:
    frame: int
    node: str
    digest: str  # 32 hex digits
    particles: int
    emitters: int
    cost_us: tuple[int, ...]  # microseconds of each of PHASES (cavesim/core/frame_cost.py)
    rejected: int = 0  # messages this node has rejected so far
    status: Status = Status.STEPPED
    sample: DriftSample | None = None  # mixed-hardware mode: its records sample_indices names
    # the frame's counters the node counted, as (id, values) (`cavesim.core.counters.entries`);
    # a receiver skips an id it does not know
    counters: tuple[tuple[int, tuple[int, ...]], ...] = ()


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
    scene: str = ""  # the digest of the node's scene (`cavesim.core.scene.digest`)
    engine: Engine = Engine.GS_TF  # the particle engine path it steps with
    auto: bool = False  # `engine` is its probe's choice: it steps with the run's path

    @classmethod
    def of_gpu(cls, frame: int, node: str, gpu: Mapping, swap_locked: bool = False,
               nonce: int = 0, scene: str = "", engine: Engine = Engine.GS_TF,
               auto: bool = False) -> InfoMessage:
        """The message for a GPU as `cavesim.gpu.gl.context.gpu_of` describes it; characters
        the wire cannot carry become '?', and long strings are cut to MAX_TEXT."""
        def fit(text: str) -> str:
            return "".join(c if " " <= c <= "~" else "?" for c in text)[:MAX_TEXT]

        return cls(frame, node, gpu["device"], gpu["kind"] == "software", fit(gpu["renderer"]),
                   fit(gpu["vendor"]), fit(gpu["version"]), swap_locked, nonce, scene, engine,
                   auto)

    def gpu(self) -> dict:
        """The GPU as `gpu_of` describes it, and the engine path it ran, for report.json."""
        return {"device": self.device, "kind": "software" if self.software else "hardware",
                "renderer": self.renderer, "vendor": self.vendor, "version": self.version,
                "engine": self.engine.value, "engine_probed": self.auto}


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


def write_report(m: ReportMessage) -> bytes:
    if len(m.cost_us) != len(PHASES):
        raise ValueError(f"a report times the {len(PHASES)} phases {', '.join(PHASES)}, got "
                         f"{len(m.cost_us)} times")
    body = name_bytes(m.node) + _REPORT.pack(
        digest_bytes(m.digest), m.particles, m.emitters, *m.cost_us, m.rejected, m.status)
    body += _counter_bytes(m.counters)
    if m.sample is None:  # the bit-exact mode's report: no tail
        return body
    if len(m.sample) > m.particles:
        raise ValueError(f"a drift sample holds at most the {m.particles} live records, got "
                         f"{len(m.sample)}")
    return body + _SAMPLE.pack(len(m.sample)) + m.sample.records


def read_report(frame: int, payload: bytes) -> ReportMessage:
    node, rest = read_name(payload)
    if len(rest) < _REPORT.size:
        raise ProtocolError("bad-payload", f"report body of {len(rest)} bytes, "
                                           f"expected {_REPORT.size}")
    digest, particles, emitters, *cost_us, rejected, status = _REPORT.unpack_from(rest)
    if status not in Status.__members__.values():
        raise ProtocolError("bad-value", f"report status {status} is unknown")
    counters, tail = _read_counters(rest[_REPORT.size:])
    sample = _read_sample(tail, particles) if tail else None
    return ReportMessage(frame, node, digest.hex(), particles, emitters, tuple(cost_us),
                         rejected, Status(status), sample, counters)


def _counter_bytes(counters: tuple[tuple[int, tuple[int, ...]], ...]) -> bytes:
    """The counter tail: its entries, each (id, value count, values)."""
    if len(counters) > MAX_ENTRIES:
        raise ValueError(f"a report carries at most {MAX_ENTRIES} counters, got {len(counters)}")
    out = [_COUNTERS.pack(len(counters))]
    for id_, values in counters:
        if problem := _entry_problem(id_, len(values)):
            raise ValueError(problem)
        if any(not 0 <= v < 2**32 for v in values):
            raise ValueError(f"counter {id_}'s values must be in [0, 2**32), got {values}")
        out.append(_ENTRY.pack(id_, len(values)) + struct.pack(f"<{len(values)}I", *values))
    if len({id_ for id_, _ in counters}) != len(counters):
        raise ValueError(f"a report names each counter once, got ids "
                         f"{[id_ for id_, _ in counters]}")
    return b"".join(out)


def _entry_problem(id_: int, count: int) -> str | None:
    """Why an entry of counter `id_` with `count` values is malformed (None: it is not). A
    known counter has its row's number of values (a per-class one, one per class); any
    counter at most MAX_VALUES."""
    if not 1 <= id_ <= MAX_ID:
        return f"a counter's id must be in [1, {MAX_ID}], got {id_}"
    if count > MAX_VALUES:
        return f"counter {id_} has {count} values, at most {MAX_VALUES} are allowed"
    row = BY_ID.get(id_)
    if row is None:
        return None  # a counter of a newer build: its receiver skips it
    if row.per_class and not 1 <= count <= MAX_PARTICLE_CLASSES:
        return (f"counter {id_} ({row.name}) has a value per particle class, 1 to "
                f"{MAX_PARTICLE_CLASSES}, got {count}")
    if not row.per_class and count != row.values:
        return f"counter {id_} ({row.name}) has {row.values} value(s), got {count}"
    return None


def _read_counters(tail: bytes) -> tuple[tuple[tuple[int, tuple[int, ...]], ...], bytes]:
    """A report's counter tail (within MAX_ENTRIES entries, each well formed, each id once)
    and what follows it."""
    if len(tail) < _COUNTERS.size:
        raise ProtocolError("bad-payload", "a report ends before its count of counters")
    (count,) = _COUNTERS.unpack_from(tail)
    if count > MAX_ENTRIES:
        raise ProtocolError("bad-payload", f"a report of {count} counters: at most "
                                           f"{MAX_ENTRIES} are allowed")
    at, entries = _COUNTERS.size, []
    for _ in range(count):
        if len(tail) < at + _ENTRY.size:
            raise ProtocolError("bad-payload", f"counter {len(entries) + 1} of {count} runs "
                                               f"past the end of the report")
        id_, values = _ENTRY.unpack_from(tail, at)
        if problem := _entry_problem(id_, values):
            raise ProtocolError("bad-payload", problem)
        end = at + _ENTRY.size + 4 * values
        if len(tail) < end:
            raise ProtocolError("bad-payload", f"counter {id_}'s {values} values run past the "
                                               f"end of the report")
        if any(id_ == seen for seen, _ in entries):
            raise ProtocolError("bad-payload", f"counter {id_} comes twice in one report")
        entries.append((id_, struct.unpack_from(f"<{values}I", tail, at + _ENTRY.size)))
        at = end
    return tuple(entries), tail[at:]


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


def write_info(m: InfoMessage) -> bytes:
    if not 0 <= m.device <= 0xFFFF:
        raise ValueError(f"EGL device index must be in [0, 65535], got {m.device}")
    texts = b"".join(_text_bytes(what, getattr(m, what))
                     for what in ("renderer", "vendor", "version"))
    flags = (INFO_SOFTWARE if m.software else 0) | (INFO_SWAP_LOCKED if m.swap_locked else 0) \
        | (INFO_COMPUTE if m.engine is Engine.COMPUTE else 0) | (INFO_AUTO if m.auto else 0)
    if not 0 <= m.nonce < 2**64:
        raise ValueError(f"nonce must be in [0, 2**64), got {m.nonce}")
    scene = digest_bytes(m.scene) if m.scene else bytes(16)
    return name_bytes(m.node) + _INFO.pack(m.device, flags, m.nonce, scene) + texts


def read_info(frame: int, payload: bytes) -> InfoMessage:
    node, rest = read_name(payload)
    if len(rest) < _INFO.size:
        raise ProtocolError("bad-payload", f"info body of {len(rest)} bytes is too short")
    device, flags, nonce, scene = _INFO.unpack_from(rest)
    defined = INFO_SOFTWARE | INFO_SWAP_LOCKED | INFO_COMPUTE | INFO_AUTO
    if flags & ~defined:
        raise ProtocolError("bad-value", f"info flags {flags:#x}: only {defined:#x} are "
                                         f"defined")
    rest = rest[_INFO.size:]
    texts = []
    for _ in range(3):
        text, rest = _read_text(rest)
        texts.append(text)
    if rest:
        raise ProtocolError("bad-payload", f"{len(rest)} stray bytes after an info message")
    return InfoMessage(frame, node, device, bool(flags & INFO_SOFTWARE), *texts,
                       swap_locked=bool(flags & INFO_SWAP_LOCKED), nonce=nonce,
                       scene=scene.hex() if any(scene) else "",
                       engine=Engine.COMPUTE if flags & INFO_COMPUTE else Engine.GS_TF,
                       auto=bool(flags & INFO_AUTO))


def write_display(m: DisplayMessage) -> bytes:
    if not 0 <= m.time_ns < 2**64:
        raise ValueError(f"time_ns must be in [0, 2**64), got {m.time_ns}")
    return name_bytes(m.node) + _DISPLAY.pack(Phase(m.phase), m.time_ns)


def read_display(frame: int, payload: bytes) -> DisplayMessage:
    node, rest = read_name(payload)
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
