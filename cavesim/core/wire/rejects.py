"""Counting and logging rejected messages: a receiver never crashes on bad input."""

from __future__ import annotations

import logging
from collections import Counter

from cavesim.core.errors import ProtocolError

log = logging.getLogger("cavesim.wire")


class RejectCounter:
    """Per-reason counts of rejected messages, each logged once it happens."""

    def __init__(self, receiver: str) -> None:
        self.receiver = receiver
        self.counts: Counter[str] = Counter()

    def reject(self, error: ProtocolError, key: str) -> None:
        self.counts[error.reason] += 1
        log.warning("%s rejected a message on %s: %s", self.receiver, key, error)

    @property
    def total(self) -> int:
        return sum(self.counts.values())
