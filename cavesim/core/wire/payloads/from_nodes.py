"""What a wall node sends the master: its report of a frame (with a drift sample in the
mixed-hardware mode), its GPU when asked, and its steps of the swap barrier."""

from __future__ import annotations

import struct
from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum

from cavesim.core.drift import MAX_SAMPLE, SAMPLE_DTYPE, DriftSample
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Engine
from cavesim.core.substeps import SUBSTEP_COUNTS
from cavesim.core.wire.payloads._fields import digest_bytes, name_bytes, read_name

MAX_TEXT = 255  # characters of one string of an info message (a one-byte length)
# digest, counts (live particles, emitters, new particles dropped at the capacity), each
# phase's microseconds (FRAME_PHASES), rejected, status
_REPORT = struct.Struct(f"<16sIII{len(PHASES)}IIB")
_EXITS = struct.Struct("<B")  # classes whose domain exits follow, a uint each (0: not counted)
_SUBSTEPS = struct.Struct("<B")  # uints of adaptive tracers' substeps that follow: 0 or 3
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
    # per particle class, those that left the field's box this frame; () where not counted
    domain_exits: tuple[int, ...] = ()
    dropped: int = 0  # new particles this frame that the full capacity dropped
    # adaptive tracers' substeps this frame: taken, retaken, the most of one tracer
    # (cavesim.core.substeps.SubstepCounts); () where not counted
    tracer_substeps: tuple[int, ...] = ()


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
    if len(m.domain_exits) > MAX_PARTICLE_CLASSES:
        raise ValueError(f"a report counts exits of at most {MAX_PARTICLE_CLASSES} classes, "
                         f"got {len(m.domain_exits)}")
    if not 0 <= m.dropped < 2**32:
        raise ValueError(f"a report's dropped count must be in [0, 2**32), got {m.dropped}")
    body = name_bytes(m.node) + _REPORT.pack(
        digest_bytes(m.digest), m.particles, m.emitters, m.dropped, *m.cost_us, m.rejected,
        m.status)
    body += _EXITS.pack(len(m.domain_exits)) + struct.pack(f"<{len(m.domain_exits)}I",
                                                            *m.domain_exits)
    if len(m.tracer_substeps) not in (0, SUBSTEP_COUNTS):
        raise ValueError(f"a report's tracer substeps are {SUBSTEP_COUNTS} counts or none, got "
                         f"{len(m.tracer_substeps)}")
    body += _SUBSTEPS.pack(len(m.tracer_substeps)) + struct.pack(
        f"<{len(m.tracer_substeps)}I", *m.tracer_substeps)
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
    digest, particles, emitters, dropped, *cost_us, rejected, status = \
        _REPORT.unpack_from(rest)
    if status not in Status.__members__.values():
        raise ProtocolError("bad-value", f"report status {status} is unknown")
    if dropped and not particles:  # a frame drops only what a full pool cannot take
        raise ProtocolError("bad-value", f"a report drops {dropped} particles at the "
                                         f"capacity with none live: a drop needs a full pool")
    exits, tail = _read_exits(rest[_REPORT.size:])
    substeps, tail = _read_substeps(tail)
    sample = _read_sample(tail, particles) if tail else None
    return ReportMessage(frame, node, digest.hex(), particles, emitters, tuple(cost_us),
                         rejected, Status(status), sample, exits, dropped, substeps)


def _read_exits(tail: bytes) -> tuple[tuple[int, ...], bytes]:
    """A report's domain exits (a class count within MAX_PARTICLE_CLASSES, a uint each) and
    what follows them."""
    if len(tail) < _EXITS.size:
        raise ProtocolError("bad-payload", "a report ends before its count of domain exits")
    (classes,) = _EXITS.unpack_from(tail)
    end = _EXITS.size + 4 * classes
    if classes > MAX_PARTICLE_CLASSES or len(tail) < end:
        raise ProtocolError("bad-payload", f"domain exits of {classes} classes in "
                                           f"{len(tail) - _EXITS.size} bytes: expected at most "
                                           f"{MAX_PARTICLE_CLASSES} classes of 4 bytes each")
    return struct.unpack_from(f"<{classes}I", tail, _EXITS.size), tail[end:]


def _read_substeps(tail: bytes) -> tuple[tuple[int, ...], bytes]:
    """A report's tracer substeps (none, or taken, retaken and most) and what follows."""
    if len(tail) < _SUBSTEPS.size:
        raise ProtocolError("bad-payload", "a report ends before its count of tracer substeps")
    (counts,) = _SUBSTEPS.unpack_from(tail)
    end = _SUBSTEPS.size + 4 * counts
    if counts not in (0, SUBSTEP_COUNTS) or len(tail) < end:
        raise ProtocolError("bad-payload", f"tracer substeps of {counts} counts in "
                                           f"{len(tail) - _SUBSTEPS.size} bytes: expected 0 or "
                                           f"{SUBSTEP_COUNTS} counts of 4 bytes each")
    return struct.unpack_from(f"<{counts}I", tail, _SUBSTEPS.size), tail[end:]


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
