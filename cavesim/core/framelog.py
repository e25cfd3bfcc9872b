"""The master's frame log: every frame's inputs and the checksum the cluster agreed on.

A JSON header line, then one record per frame, appended as the frame is agreed:

    u32 payload size | u32 CRC32 of those 4 bytes | payload | u32 CRC32 of the payload
    payload = the frame message (as sent, unsigned) | 16-byte agreed digest | u32 live count

`cavesim replay` steps one engine through the inputs and must reproduce every digest bit
for bit. The size has a check of its own so that a damaged size is told from a torn tail.

Crash safety. Each record is flushed to the kernel as it is written, so a crash or SIGKILL
of the master loses nothing that was appended. A power loss can still take what the
kernel had not written back; the log is fsynced at most once per SYNC_SECONDS and on
close. An fsync per record cost 0.3-1.1 ms on this machine (ext4 on virtio, 2 cores),
against 2-4 us for the flush: up to a whole frame of a 1,000 frames/s run; once a
second it is under 0.1%. A reader takes every whole record whose checks pass and stops at
the first that is not (`Damage`): a torn tail (the writer stopped inside a record: a
crash, a full disk) or a corrupt record; nothing after it is read, as every frame
depends on the ones before.

The header names the session, the scene's path and its digest (`scene_digest`, of its
content: `cavesim.core.scene.digest`), the walls and the clock's seed, and the run's
planned frames and nominal dt (which fix a replay's trajectory selection); a log written
before the digest was added has none, and a replay says so.

Version 2 added the checks; version 1 logs are refused, not read: they are
replayed by the build that wrote them (the wire format they hold changes with builds too).
"""

from __future__ import annotations

import json
import os
import struct
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from zlib import crc32

from cavesim.core.output import writing
from cavesim.core.wire import FrameMessage, decode, encode
from cavesim.core.wire.envelope import FRAME_VERSIONS

FRAME_LOG = "frames.log"  # the name a run gives its frame log, in its folder

FORMAT = "cavesim-frame-log"
VERSION = 3  # 3: digests of records that keep the position's low part (position.py)
SYNC_SECONDS = 1.0  # most time between fsyncs: what a power loss may take
TORN, CORRUPT = "torn", "corrupt"
_U32 = struct.Struct("<I")  # a payload size or a CRC32
_TAIL = struct.Struct("<16sI")  # the agreed digest and live particle count


@dataclass(frozen=True)
class LoggedFrame:
    message: FrameMessage
    digest: str
    particles: int


@dataclass(frozen=True)
class Damage:
    """Where a frame log stops being readable; every record before it is whole."""

    kind: str  # TORN: the file ends inside a record; CORRUPT: a record fails its check
    offset: int  # the byte that record starts at
    size: int  # bytes from there to the end of the file, none of them read
    whole_records: int  # records before it

    def describe(self) -> str:
        if self.kind == TORN:
            return (f"torn tail at byte {self.offset}: the last {self.size} bytes are an "
                    f"unfinished record (the writer stopped: a crash or a full disk), after "
                    f"{self.whole_records} whole records")
        return (f"corrupt record at byte {self.offset} (its checksum does not match), after "
                f"{self.whole_records} whole records; the {self.size} bytes from there on "
                f"are not read")

    def to_json(self) -> dict:
        return asdict(self)


class FrameLogWriter:
    """Appends one checked record per frame; an OSError is an OutputError naming the file."""

    def __init__(self, path: Path, header: dict) -> None:
        self.path = Path(path)
        self.session = header["session"]
        line = json.dumps({"format": FORMAT, "version": VERSION, **header}) + "\n"
        with writing(self.path):
            self._file = open(self.path, "wb")  # noqa: SIM115 - closed by close()
            self._file.write(line.encode())
            self._file.flush()
        self._synced = time.monotonic()

    def append(self, message: FrameMessage, digest: str, particles: int) -> None:
        payload = encode(message, self.session) + _TAIL.pack(bytes.fromhex(digest), particles)
        size = _U32.pack(len(payload))
        with writing(self.path):
            self._file.write(size + _U32.pack(crc32(size)) + payload + _U32.pack(crc32(payload)))
            self._file.flush()
            if time.monotonic() - self._synced >= SYNC_SECONDS:
                os.fsync(self._file.fileno())
                self._synced = time.monotonic()

    def close(self) -> None:
        """Flush and fsync; an OutputError if the file was deleted while it was written."""
        with writing(self.path):
            try:
                self._file.flush()
                os.fsync(self._file.fileno())
                deleted = os.fstat(self._file.fileno()).st_nlink == 0
            finally:
                self._file.close()
            if deleted:
                raise FileNotFoundError(2, "it was deleted while the run wrote it")


class LoggedFrames:
    """The whole, checked records of a frame log, decoded as they are iterated; `damage`
    says where the rest, if any, stops being readable."""

    def __init__(self, data: bytes, spans: list[tuple[int, int]], session: str,
                 damage: Damage | None) -> None:
        self._data = data
        self._spans = spans  # each record's payload: [start, end)
        self._session = session
        self.damage = damage

    def __len__(self) -> int:
        return len(self._spans)

    def __iter__(self) -> Iterator[LoggedFrame]:
        for start, end in self._spans:
            digest, particles = _TAIL.unpack_from(self._data, end - _TAIL.size)
            frame = decode(self._data[start:end - _TAIL.size], self._session,
                           versions=FRAME_VERSIONS)
            yield LoggedFrame(frame, digest.hex(), particles)


def read_frame_log(path: Path) -> tuple[dict, LoggedFrames]:
    """The header and the whole records; ValueError if the file is no version-2 frame log."""
    data = Path(path).read_bytes()
    end = data.find(b"\n")
    try:
        header = json.loads(data[:end]) if end >= 0 else None
    except ValueError:
        header = None
    if not isinstance(header, dict):
        raise ValueError(f"{path}: not a cavesim frame log (no JSON header line)")
    if header.get("format") != FORMAT or header.get("version") != VERSION:
        raise ValueError(f"{path}: format {header.get('format')!r} version "
                         f"{header.get('version')!r}, expected {FORMAT!r} {VERSION}")
    spans, damage = _scan(data, end + 1)
    return header, LoggedFrames(data, spans, header["session"], damage)


def _scan(data: bytes, offset: int) -> tuple[list[tuple[int, int]], Damage | None]:
    """The payload spans of the whole records from `offset` on, and where that stops."""
    view, spans = memoryview(data), []

    def damage(kind: str) -> Damage:
        return Damage(kind, offset, len(data) - offset, len(spans))

    while offset < len(data):
        start = offset + 2 * _U32.size
        if start > len(data):
            return spans, damage(TORN)
        (size,), (size_check,) = _U32.unpack_from(data, offset), \
            _U32.unpack_from(data, offset + _U32.size)
        if crc32(view[offset:offset + _U32.size]) != size_check:
            return spans, damage(CORRUPT)
        end = start + size
        if end + _U32.size > len(data):
            return spans, damage(TORN)
        (check,) = _U32.unpack_from(data, end)
        if crc32(view[start:end]) != check:
            return spans, damage(CORRUPT)
        spans.append((start, end))
        offset = end + _U32.size
    return spans, None
