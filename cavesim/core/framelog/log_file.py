"""The frame log's file: a JSON header line, then one checked record per frame, appended by
the master as each frame is agreed and read back by a replay.

    u32 payload size | u32 CRC32 of those 4 bytes | payload | u32 CRC32 of the payload

The payload is a record of the version the header line names (READERS): this build writes
version 4 (version4.py) and reads 3 as well (_version3.py). The size has a check of its own
so that a damaged size is told from a torn tail.

Crash safety. Each record is flushed to the kernel as it is written, so a crash or SIGKILL
of the master loses nothing that was appended. A power loss can still take what the
kernel had not written back; the log is fsynced at most once per SYNC_SECONDS and on
close. An fsync per record cost 0.3-1.1 ms on this machine (ext4 on virtio, 2 cores),
against 2-4 us for the flush: up to a whole frame of a 1,000 frames/s run; once a
second it is under 0.1%. A reader takes every whole record whose checks pass and stops at
the first that is not (`Damage`): a torn tail (the writer stopped inside a record: a
crash, a full disk) or a corrupt record; nothing after it is read, as every frame
depends on the ones before. A whole record that does not parse (a writer's bug, not
damage) is a `FrameLogError` naming its byte, raised when it is reached. A reader takes
only a regular file within MAX_FRAME_LOG_BYTES, whose header line ends within
MAX_FRAME_LOG_HEADER_BYTES and nests at most MAX_NESTING levels (`cavesim.core.limits`).
"""

from __future__ import annotations

import json
import os
import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from zlib import crc32

from cavesim.core._json import parse_json
from cavesim.core.errors import CavesimError
from cavesim.core.framelog import _version3, version4
from cavesim.core.framelog.version4 import VERSION, LoggedFrame
from cavesim.core.input_files import read_input
from cavesim.core.limits import MAX_FRAME_LOG_BYTES, MAX_FRAME_LOG_HEADER_BYTES
from cavesim.core.output import writing
from cavesim.core.wire import FrameMessage

FRAME_LOG = "frames.log"  # the name a run gives its frame log, in its folder

FORMAT = "cavesim-frame-log"
# how each version's records read, given the header line; versions 1 and 2 are refused
# (they are replayed by the build that wrote them)
READERS: dict[int, Callable[[dict], Callable[[bytes], LoggedFrame]]] = {
    _version3.VERSION: _version3.record_reader, VERSION: version4.record_reader}
SYNC_SECONDS = 1.0  # most time between fsyncs: what a power loss may take
TORN, CORRUPT = "torn", "corrupt"
_U32 = struct.Struct("<I")  # a payload size or a CRC32


class FrameLogError(CavesimError, ValueError):
    """A file this build does not read as a frame log: no header line, another format or
    version, or a whole record that does not parse; names the file (and the record)."""


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
    """Appends one checked record of version 4 per frame; an OSError is an OutputError
    naming the file. The header line's format and version are the writer's: a `header`
    copied from another log keeps only its other keys."""

    def __init__(self, path: Path, header: dict) -> None:
        self.path = Path(path)
        fields = {"format": FORMAT, "version": VERSION}
        fields.update((key, value) for key, value in header.items() if key not in fields)
        with writing(self.path):
            self._file = open(self.path, "wb")  # noqa: SIM115 - closed by close()
            self._file.write(json.dumps(fields).encode() + b"\n")
            self._file.flush()
        self._synced = time.monotonic()

    def append(self, message: FrameMessage, digest: str, particles: int) -> None:
        """Append the frame and what the walls agreed on after it; ValueError names a value
        the record cannot hold."""
        payload = version4.write_record(message, digest, particles)
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
    """The whole, checked records of a frame log, read as they are iterated (FrameLogError
    at one that does not parse); `damage` says where the rest, if any, stops being
    readable."""

    def __init__(self, path: Path, data: bytes, spans: list[tuple[int, int]],
                 read: Callable[[bytes], LoggedFrame], damage: Damage | None) -> None:
        self._path = path
        self._data = data
        self._spans = spans  # each record's payload: [start, end)
        self._read = read
        self.damage = damage

    def __len__(self) -> int:
        return len(self._spans)

    def __iter__(self) -> Iterator[LoggedFrame]:
        for start, end in self._spans:
            try:
                logged = self._read(self._data[start:end])
            except ValueError as e:
                raise FrameLogError(f"{self._path}: the record at byte {start - 2 * _U32.size} "
                                    f"passes its checks but does not read: {e}") from e
            yield logged


def read_frame_log(path: Path) -> tuple[dict, LoggedFrames]:
    """The header and the whole records; FrameLogError if the file is no frame log of a
    version this build reads, or no regular file within MAX_FRAME_LOG_BYTES."""
    data = read_input(path, FrameLogError, "the frame log", MAX_FRAME_LOG_BYTES)
    end = data.find(b"\n", 0, MAX_FRAME_LOG_HEADER_BYTES)
    header = None if end < 0 else parse_json(data[:end], FrameLogError,
                                             f"{path}: not a cavesim frame log", "its header line")
    if not isinstance(header, dict):
        raise FrameLogError(f"{path}: not a cavesim frame log (no JSON header line in its "
                            f"first {MAX_FRAME_LOG_HEADER_BYTES:,} bytes)")
    if header.get("format") != FORMAT:
        raise FrameLogError(f"{path}: format {header.get('format')!r}, expected {FORMAT!r}")
    version = header.get("version")
    if type(version) is not int or version not in READERS:
        raise FrameLogError(f"{path}: {FORMAT} version {version!r}; this build reads versions "
                            f"{' and '.join(map(str, READERS))} (a version 1 or 2 log is "
                            f"replayed by the build that wrote it)")
    try:
        read = READERS[version](header)
    except ValueError as e:
        raise FrameLogError(f"{path}: {e}") from e
    spans, damage = _scan(data, end + 1)
    return header, LoggedFrames(Path(path), data, spans, read, damage)


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
