"""Counting and logging rejected messages: a receiver never crashes on bad input, and a flood
of bad input never floods its log.

The master and every node keep one `RejectCounter`; it may be called from their loops and
from Zenoh's callback threads at once (it holds a lock). Counts are exact; the log is
rate-limited per reason: the first reject of a reason is logged at once, later ones at most
once per `interval`, as one line saying how many more came (written when a reject arrives
after the interval: no timer thread), and `flush()` writes what is left and the exact
counts at the end of a run. `guarded` wraps a Zenoh callback so that nothing it raises
escapes to Zenoh's thread (which would print a traceback per message): it is counted as
`callback-failed` and logged like any reject.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cavesim.core.errors import ProtocolError

log = logging.getLogger("cavesim.wire")
LOG_INTERVAL = 10.0  # s: at most one line per reason per interval after its first


@dataclass
class _Unlogged:
    """Rejects of one reason since its last log line."""

    since: float  # when that line was written (the counter's clock)
    count: int = 0
    error: ProtocolError | None = None  # the latest one, and where it came
    key: str = ""


class RejectCounter:
    """Exact per-reason counts of rejected messages, logged at a bounded rate."""

    def __init__(self, receiver: str, interval: float = LOG_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.receiver = receiver
        self.interval = interval
        self.clock = clock
        self._counts: Counter[str] = Counter()
        self._total = 0
        self._unlogged: dict[str, _Unlogged] = {}  # reason -> since its last line
        self._lock = threading.Lock()

    def reject(self, error: ProtocolError, key: str) -> None:
        """Count `error` (a message on `key` was rejected); log it if the rate allows."""
        now = self.clock()
        with self._lock:
            self._counts[error.reason] += 1
            self._total += 1
            unlogged = self._unlogged.get(error.reason)
            if unlogged is None:
                self._unlogged[error.reason] = _Unlogged(now)
                line = self._first_line(error, key)
            else:
                unlogged.count += 1
                unlogged.error, unlogged.key = error, key
                line = None
                if now - unlogged.since >= self.interval:
                    line = self._more_line(error.reason, unlogged, now)
                    self._unlogged[error.reason] = _Unlogged(now)
        if line is not None:
            log.warning(line)

    def guarded(self, name: str, callback: Callable[[Any], None]) -> Callable[[Any], None]:
        """`callback` (called `name` in the log) for Zenoh's threads: whatever it raises is
        counted as a `callback-failed` reject and logged at the same bounded rate, in one
        line and without a traceback. A last resort: callbacks refuse bad input themselves."""
        def run(received: Any) -> None:
            try:
                callback(received)
            except Exception as e:  # noqa: BLE001 - nothing may reach Zenoh's thread
                text = " ".join(str(e).split()) or "no message"
                self.reject(ProtocolError("callback-failed", f"{name} raised "
                                                             f"{type(e).__name__}: {text}"),
                            _key_of(received))
        return run

    def flush(self) -> None:
        """Log the rejects not yet logged, and one closing line with every reason's exact
        count (nothing when there were none); for the end of a run."""
        now = self.clock()
        with self._lock:
            lines = [self._more_line(reason, unlogged, now)
                     for reason, unlogged in self._unlogged.items() if unlogged.count]
            for unlogged in self._unlogged.values():
                unlogged.count, unlogged.since = 0, now
            if self._total:
                by_reason = ", ".join(f"{reason} {n:,}" for reason, n in
                                      self._counts.most_common())
                lines.append(f"{self.receiver} rejected {self._total:,} "
                             f"{_messages(self._total)} in all: {by_reason}")
        for line in lines:
            log.warning(line)

    @property
    def counts(self) -> Counter[str]:
        """A copy of the per-reason counts."""
        with self._lock:
            return Counter(self._counts)

    @property
    def total(self) -> int:
        with self._lock:
            return self._total

    def _first_line(self, error: ProtocolError, key: str) -> str:
        return f"{self.receiver} rejected a message on {key}: {error}"

    def _more_line(self, reason: str, unlogged: _Unlogged, now: float) -> str:
        return (f"{self.receiver} rejected {unlogged.count:,} more {reason} "
                f"{_messages(unlogged.count)} in the last {now - unlogged.since:.0f} s "
                f"({self._counts[reason]:,} in all); the last on {unlogged.key}: "
                f"{unlogged.error}")


def _key_of(received: Any) -> str:
    """The key a sample or query came on, where it can still be read."""
    try:
        return str(received.key_expr)
    except Exception:  # noqa: BLE001 - a dropped query, or a reply, has none to read
        return "a reply or dropped query"


def _messages(count: int) -> str:
    return "message" if count == 1 else "messages"
