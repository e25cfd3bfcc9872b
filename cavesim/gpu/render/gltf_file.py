"""A glTF 2.0 file's JSON and buffers, read within the limits before anything of it is
walked (`gltf_model.py` makes the model of them).

The file (JSON, or binary .glb: a 12-byte header, a JSON chunk, an optional BIN chunk) and
each buffer file a relative `uri` names are read only if they are regular files, MAX_MODEL_BYTES
together at most, counting each buffer by its declared byteLength before it is read. The JSON
may nest MAX_NESTING levels (scanned before it is parsed) and hold MAX_MODEL_NODES nodes.
Nothing beyond `json` parses it: a generic glTF library decodes each object into a class,
some milliseconds each, which a file of many nodes turns into minutes.
"""

from __future__ import annotations

import base64
import binascii
import struct
from dataclasses import dataclass
from pathlib import Path

from cavesim.core._json import parse_json
from cavesim.core.errors import ModelError
from cavesim.core.input_files import read_input
from cavesim.core.limits import MAX_MODEL_BYTES, MAX_MODEL_NODES

GLB_MAGIC, GLB_VERSION = b"glTF", 2
_GLB_HEADER = struct.Struct("<4sII")  # magic, version, length of the whole file
_CHUNK_HEADER = struct.Struct("<I4s")  # length, type
JSON_CHUNK, BIN_CHUNK = b"JSON", b"BIN\x00"


@dataclass(frozen=True)
class GltfFile:
    """The JSON document of a glTF file and the bytes of each of its buffers."""

    document: dict
    buffers: tuple[bytes, ...]


def read_gltf(path: Path) -> GltfFile:
    """The glTF file at `path` within the limits; ModelError names the file and what is
    wrong (without what a model must be: the caller adds it)."""
    data = read_input(path, ModelError, "the model file", MAX_MODEL_BYTES)
    text, blob = _glb_chunks(path, data) if Path(path).suffix.lower() == ".glb" else (data, None)
    document = parse_json(text, ModelError, str(path), "its glTF JSON")
    if not isinstance(document, dict):
        raise ModelError(f"{path}: its glTF JSON is a {type(document).__name__}, not an object")
    nodes = document.get("nodes", [])
    if isinstance(nodes, list) and len(nodes) > MAX_MODEL_NODES:
        raise ModelError(f"{path}: {len(nodes):,} nodes; at most MAX_MODEL_NODES = "
                         f"{MAX_MODEL_NODES:,} are read")
    return GltfFile(document, _buffers(path, document, blob, MAX_MODEL_BYTES - len(data)))


def _glb_chunks(path: Path, data: bytes) -> tuple[bytes, bytes | None]:
    """The JSON chunk and the BIN chunk (None without one) of a binary glTF file."""
    if len(data) < _GLB_HEADER.size or data[:4] != GLB_MAGIC:
        raise ModelError(f"{path}: not a .glb file: it begins {data[:4]!r}, a .glb file "
                         f"{GLB_MAGIC!r} and a 12-byte header")
    _, version, length = _GLB_HEADER.unpack_from(data)
    if version != GLB_VERSION or length != len(data):
        raise ModelError(f"{path}: a .glb file of version {version} and length {length}; "
                         f"expected version {GLB_VERSION} and the file's {len(data)} bytes")
    chunks, offset = [], _GLB_HEADER.size
    while offset + _CHUNK_HEADER.size <= len(data) and len(chunks) < 2:
        size, kind = _CHUNK_HEADER.unpack_from(data, offset)
        start = offset + _CHUNK_HEADER.size
        if start + size > len(data):
            raise ModelError(f"{path}: its chunk at byte {offset} runs {start + size - len(data)} "
                             f"bytes past the end of the file")
        chunks.append((kind, data[start:start + size]))
        offset = start + size
    if not chunks or chunks[0][0] != JSON_CHUNK:
        raise ModelError(f"{path}: a .glb file whose first chunk is not its JSON")
    blob = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == BIN_CHUNK else None
    return chunks[0][1], blob


def _buffers(path: Path, document: dict, blob: bytes | None,
             budget: int) -> tuple[bytes, ...]:
    """Each buffer's bytes: the .glb's BIN chunk, a data URI's or a file's beside `path`,
    the declared byteLengths held to `budget` before any is read."""
    buffers = document.get("buffers", [])
    if not isinstance(buffers, list) or not all(isinstance(b, dict) for b in buffers):
        raise ModelError(f"{path}: its buffers are not a list of objects")
    lengths = [b.get("byteLength") for b in buffers]
    if not all(type(n) is int and n >= 0 for n in lengths):
        raise ModelError(f"{path}: buffer byteLengths {lengths[:8]}; each must be an integer "
                         f">= 0")
    beside = sum(n for b, n in zip(buffers, lengths, strict=True) if _is_file(b.get("uri")))
    if beside > budget:
        raise ModelError(f"{path}: its buffer files declare {beside:,} bytes; with the file's "
                         f"own, at most MAX_MODEL_BYTES = {MAX_MODEL_BYTES:,} are read")
    read = []
    for index, (buffer, length) in enumerate(zip(buffers, lengths, strict=True)):
        data = _buffer_data(path, index, buffer.get("uri"), blob, budget)
        if len(data) < length:
            raise ModelError(f"{path}: buffer {index} holds {len(data)} bytes, fewer than its "
                             f"byteLength {length}")
        if _is_file(buffer.get("uri")):
            budget -= len(data)
        read.append(data[:length])
    return tuple(read)


def _is_file(uri: object) -> bool:
    """Whether a buffer's uri names a file (not a data URI, nor the .glb's own chunk)."""
    return isinstance(uri, str) and not uri.startswith("data:")


def _buffer_data(path: Path, index: int, uri: object, blob: bytes | None,
                 budget: int) -> bytes:
    where = f"{path}: buffer {index}"
    if uri is None:
        if blob is None:
            raise ModelError(f"{where} has no uri and the file no BIN chunk")
        return blob
    if not isinstance(uri, str):
        raise ModelError(f"{where} has uri {uri!r}; expected a string")
    if uri.startswith("data:"):
        header, _, payload = uri.partition(",")
        if not header.endswith(";base64"):
            raise ModelError(f"{where} is a data URI that is not base64 ({header!r})")
        try:
            return base64.b64decode(payload, validate=True)
        except binascii.Error as e:
            raise ModelError(f"{where} is a data URI whose base64 does not decode: {e}") from e
    return read_input(path.parent / uri, ModelError, f"buffer {index} of {path}", budget)
