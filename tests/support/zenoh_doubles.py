"""Zenoh stand-ins for tests that ask questions without a network: a reply (data from a
replier, or a refusal) and a session whose every query gets the replies given, handed to
its callback as zenoh does."""

from __future__ import annotations

from types import SimpleNamespace


class Payload(bytes):
    """A zenoh payload stand-in: its bytes, and their length."""

    def to_bytes(self) -> bytes:
        return bytes(self)

    def to_string(self) -> str:
        return self.decode()


class Reply:
    """A zenoh reply stand-in: `data` from `replier`, or a refusal."""

    def __init__(self, replier: str, data: bytes | None = None, refusal: str = "") -> None:
        self.replier_id = replier
        payload = Payload(refusal.encode() if data is None else data)
        self.ok = None if data is None else SimpleNamespace(payload=payload)
        self.err = SimpleNamespace(payload=payload)


class RepliesSession:
    """A zenoh session stand-in whose every query gets the replies given, in order."""

    def __init__(self, replies: list[Reply]) -> None:
        self.replies = replies

    def get(self, key, handler, **options) -> None:
        for reply in self.replies:
            handler.callback(reply)
        handler.drop()
