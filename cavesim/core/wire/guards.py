"""What a receiver keeps so that a hostile or misconfigured peer cannot make it work without
bound or fail without a word: a rate limit for the queries it answers, and a watch for a
sender whose every message fails its signature (a --key-file that is not the session's).
Both are called from Zenoh's threads."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

SIGNATURE_REASONS = frozenset({"bad-signature", "bad-master-signature", "unsigned",
                               "unexpected-signature", "not-from-master"})
MISMATCH_AFTER = 3  # failed signatures, with none good, that make a sender's key suspect


class RateLimit:
    """A token bucket: up to `burst` at once, refilled at `rate` per second."""

    def __init__(self, rate: float, burst: int,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.rate, self.burst, self.clock = rate, burst, clock
        self._tokens, self._last = float(burst), clock()
        self._lock = threading.Lock()

    def allow(self) -> bool:
        with self._lock:
            now = self.clock()
            self._tokens = min(self.burst, self._tokens + (now - self._last) * self.rate)
            self._last = now
            if self._tokens < 1:
                return False
            self._tokens -= 1
            return True


class KeyMismatch:
    """Per sender: how many of its messages failed their signature and whether one passed.
    `note` returns a one-line hint the moment a sender becomes suspect (once per sender)."""

    def __init__(self, receiver: str) -> None:
        self.receiver = receiver
        self._failed: dict[str, int] = {}
        self._passed: set[str] = set()
        self._told: set[str] = set()
        self._lock = threading.Lock()

    def note(self, sender: str, reason: str | None) -> str | None:
        """Record one message from `sender`: `reason` is its rejection reason, None when it
        passed. The hint, the first time the sender is suspect; else None."""
        with self._lock:
            if reason is None:
                self._passed.add(sender)
                return None
            if reason not in SIGNATURE_REASONS:
                return None
            self._failed[sender] = self._failed.get(sender, 0) + 1
            if sender in self._told or not self._suspect(sender):
                return None
            self._told.add(sender)
            return self._hint(sender)

    def hint(self, sender: str) -> str | None:
        """The hint for `sender` if its key is suspect (for an error message), else None."""
        with self._lock:
            return self._hint(sender) if self._suspect(sender) else None

    def _suspect(self, sender: str) -> bool:
        return sender not in self._passed and self._failed.get(sender, 0) >= MISMATCH_AFTER

    def _hint(self, sender: str) -> str:
        return (f"every message between {self.receiver} and {sender} fails its signature "
                f"({self._failed[sender]} so far): check --key-file on both sides; the master "
                f"needs master.key and every node and tracker its own key made with it "
                f"(`cavesim keys`)")
