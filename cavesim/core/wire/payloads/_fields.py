"""The fields several payloads share: a node name and a state's digest, each with the
check its writer or its reader makes."""

from __future__ import annotations

from cavesim.core.errors import ProtocolError
from cavesim.core.wire.key_expressions import check_name


def digest_bytes(digest: str) -> bytes:
    if len(digest) != 32 or any(c not in "0123456789abcdef" for c in digest):
        raise ValueError(f"digest must be 32 lower-case hex digits, got {digest!r}")
    return bytes.fromhex(digest)


def name_bytes(name: str, optional: bool = False) -> bytes:
    if not (optional and name == ""):
        check_name("node name", name)
    return bytes([len(name)]) + name.encode()


def read_name(data: bytes, optional: bool = False) -> tuple[str, bytes]:
    if not data or len(data) < 1 + data[0]:
        raise ProtocolError("bad-payload", "a node name runs past the end of the message")
    raw, rest = data[1:1 + data[0]], data[1 + data[0]:]
    try:
        name = raw.decode("ascii")
        if not (optional and name == ""):
            check_name("node name", name)
    except (UnicodeDecodeError, ValueError) as e:
        raise ProtocolError("bad-payload", f"node name {raw!r} is not allowed") from e
    return name, rest

