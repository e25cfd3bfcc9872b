"""What a receiver keeps so that a hostile or misconfigured peer cannot make it work without
bound or fail without a word: rate limits and per-peer serving budgets for what it answers,
the nonces of the requests it took (a replayed request is refused), and a watch for a sender
whose every message fails its signature (a --key-file that is not the session's). All are
called from Zenoh's threads."""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

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


@dataclass
class _Bucket:
    """Tokens refilled at `rate` per second up to `burst`; may be overdrawn (a debt)."""

    rate: float
    burst: float
    tokens: float
    last: float

    def refill(self, now: float) -> float:
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate)
        self.last = now
        return self.tokens


class ServingBudget:
    """Per peer: how many requests a second (up to `burst` at once) and how many bytes a
    second (up to `byte_burst`) it is served. Bytes are charged after serving (`spend`), so
    one large reply may overdraw a peer's bytes: it is served again once the debt is paid.
    The `peers` most recent askers are kept; a new one past that replaces the least recent.
    """

    def __init__(self, rate: float, burst: int, byte_rate: float, byte_burst: int,
                 peers: int = 64, clock: Callable[[], float] = time.monotonic) -> None:
        self.rate, self.burst, self.byte_rate, self.byte_burst = rate, burst, byte_rate, byte_burst
        self.peers, self.clock = peers, clock
        self._budgets: OrderedDict[object, tuple[_Bucket, _Bucket]] = OrderedDict()
        self._lock = threading.Lock()

    def admit(self, peer: object) -> bool:
        """Whether `peer` may be served one more request now (a request is taken if so)."""
        with self._lock:
            requests, size = self._of(peer)
            now = self.clock()
            if requests.refill(now) < 1 or size.refill(now) <= 0:
                return False
            requests.tokens -= 1
            return True

    def spend(self, peer: object, size: int) -> None:
        """Charge `peer` the `size` bytes it was served."""
        with self._lock:
            self._of(peer)[1].tokens -= size

    def _of(self, peer: object) -> tuple[_Bucket, _Bucket]:
        budget = self._budgets.get(peer)
        if budget is None:
            now = self.clock()
            budget = (_Bucket(self.rate, self.burst, self.burst, now),
                      _Bucket(self.byte_rate, self.byte_burst, self.byte_burst, now))
            self._budgets[peer] = budget
            if len(self._budgets) > self.peers:
                self._budgets.popitem(last=False)
        self._budgets.move_to_end(peer)
        return budget


class FreshNonces:
    """The nonces of the last `size` requests taken: a request naming one of them again is
    a replay (of a request seen on the wire). A nonce is 64 random bits, so a fresh one
    repeats by chance about once in 2**64 / size requests."""

    def __init__(self, size: int = 16_384) -> None:
        self.size = size
        self._seen: OrderedDict[int, None] = OrderedDict()
        self._lock = threading.Lock()

    def take(self, nonce: int) -> bool:
        """True and remembered if `nonce` is fresh; False if it was taken before."""
        with self._lock:
            if nonce in self._seen:
                return False
            self._seen[nonce] = None
            if len(self._seen) > self.size:
                self._seen.popitem(last=False)
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
