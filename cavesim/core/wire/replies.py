"""Waiting for a query's replies: the one way every process asks a question over Zenoh.

Zenoh hands each reply to a callback that never blocks its threads: the reply goes into a
buffer of ours, bounded in bytes, or is dropped and counted (the buffer is full, the
replier is not listened to, or the asker has stopped reading). The asker reads the buffer
on its own thread, each read waiting at most until the query's deadline; leaving the
`with` block cancels the query, so no reply is left for anyone to wait on, however the
reading ended.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import zenoh

REPLY_FLOOR = 256  # bytes a reply counts for at least, however small its payload


class Replies:
    """The replies to one query, read until its deadline (a monotonic time).

    `listen` says whether a replier (its id, as text) is still heard; `dropped` counts the
    replies not kept, `overflowed` those of them lost to a full buffer.
    """

    def __init__(self, deadline: float, limit_bytes: int,
                 listen: Callable[[str], bool] = lambda replier: True) -> None:
        self.deadline, self.limit_bytes, self.listen = deadline, limit_bytes, listen
        self.token = zenoh.CancellationToken()
        self.dropped = self.overflowed = 0
        self._buffer: deque[tuple[zenoh.Reply, int]] = deque()
        self._held = 0  # bytes in the buffer
        self._finished = self._closed = False
        self._changed = threading.Condition()

    @property
    def handler(self) -> zenoh.handlers.Callback:
        return zenoh.handlers.Callback(self._take, self._finish)

    def __iter__(self) -> Iterator[zenoh.Reply]:
        """Replies as they come, until every replier has finished or the deadline passed."""
        while (reply := self.next()) is not None:
            yield reply

    def next(self) -> zenoh.Reply | None:
        """The next reply; None once the query is over or its deadline has passed."""
        with self._changed:
            self._changed.wait_for(lambda: self._buffer or self._finished or self._closed,
                                   timeout=max(0.0, self.deadline - time.monotonic()))
            if not self._buffer or self._closed or time.monotonic() > self.deadline:
                return None
            reply, size = self._buffer.popleft()
            self._held -= size
            return reply

    def close(self) -> None:
        """Stop reading: cancel the query and let go of whatever is buffered."""
        with self._changed:
            self._closed = True
            self._buffer.clear()
            self._held = 0
            self._changed.notify_all()
        self.token.cancel()  # outside the lock: it waits for a callback that may want it

    # -- zenoh's threads ------------------------------------------------------------------

    def _take(self, reply: zenoh.Reply) -> None:
        payload = reply.ok.payload if reply.ok is not None else reply.err.payload
        size = max(REPLY_FLOOR, len(payload))
        with self._changed:
            if self._closed or not self.listen(str(reply.replier_id)):
                self.dropped += 1
            elif self._held + size > self.limit_bytes:
                self.dropped += 1
                self.overflowed += 1
            else:
                self._buffer.append((reply, size))
                self._held += size
                self._changed.notify_all()

    def _finish(self) -> None:
        with self._changed:
            self._finished = True
            self._changed.notify_all()


@contextmanager
def asking(session: zenoh.Session, key: str, deadline: float, limit_bytes: int,
           listen: Callable[[str], bool] = lambda replier: True,
           **options) -> Iterator[Replies]:
    """Send a query to `key` (`options`: those of `Session.get`); its replies while inside."""
    replies = Replies(deadline, limit_bytes, listen)
    session.get(key, replies.handler, timeout=_seconds_left(deadline),
                cancellation_token=replies.token, **options)
    try:
        yield replies
    finally:
        replies.close()


def anyone_alive(session: zenoh.Session, key: str, deadline: float) -> bool:
    """Whether a liveliness token matching `key` answers before `deadline`."""
    replies = Replies(deadline, REPLY_FLOOR)
    session.liveliness().get(key, replies.handler, timeout=_seconds_left(deadline),
                             cancellation_token=replies.token)
    try:
        return replies.next() is not None
    finally:
        replies.close()


def _seconds_left(deadline: float) -> float:
    return max(deadline - time.monotonic(), 1e-3)
