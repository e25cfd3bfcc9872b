"""The master's frame log: every frame's inputs and the checksum the cluster agreed on.

A JSON header line, then per frame: u32 length, the frame message (as sent, unsigned),
the 16-byte agreed digest and the u32 live particle count. `cavesim replay` steps one
engine through the inputs and must reproduce every digest bit for bit.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from cavesim.core.wire import FrameMessage, decode, encode

FORMAT = "cavesim-frame-log"
VERSION = 1
_TAIL = struct.Struct("<16sI")


@dataclass(frozen=True)
class LoggedFrame:
    message: FrameMessage
    digest: str
    particles: int


class FrameLogWriter:
    def __init__(self, path: Path, header: dict) -> None:
        self.session = header["session"]
        self._file = open(path, "wb")  # noqa: SIM115 - closed by close()
        line = json.dumps({"format": FORMAT, "version": VERSION, **header}) + "\n"
        self._file.write(line.encode())

    def append(self, message: FrameMessage, digest: str, particles: int) -> None:
        data = encode(message, self.session)
        self._file.write(struct.pack("<I", len(data)) + data
                         + _TAIL.pack(bytes.fromhex(digest), particles))
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def read_frame_log(path: Path) -> tuple[dict, Iterator[LoggedFrame]]:
    """The header and the logged frames; ValueError names what is wrong with the file."""
    data = Path(path).read_bytes()
    end = data.find(b"\n")
    try:
        header = json.loads(data[:end])
    except ValueError as e:
        raise ValueError(f"{path}: not a cavesim frame log (bad header line)") from e
    if header.get("format") != FORMAT or header.get("version") != VERSION:
        raise ValueError(f"{path}: format {header.get('format')!r} version "
                         f"{header.get('version')!r}, expected {FORMAT!r} {VERSION}")

    def frames() -> Iterator[LoggedFrame]:
        offset = end + 1
        while offset < len(data):
            if offset + 4 > len(data):
                raise ValueError(f"{path}: truncated record at byte {offset}")
            (length,) = struct.unpack_from("<I", data, offset)
            body = data[offset + 4:offset + 4 + length]
            tail = data[offset + 4 + length:offset + 4 + length + _TAIL.size]
            if len(body) != length or len(tail) != _TAIL.size:
                raise ValueError(f"{path}: truncated record at byte {offset}")
            digest, particles = _TAIL.unpack(tail)
            yield LoggedFrame(decode(body, header["session"]), digest.hex(), particles)
            offset += 4 + length + _TAIL.size

    return header, frames()
