"""What the preview's user asks of the run: pause, reset and stop, read once per frame from
the latest session controls (a tracking message of the preview window, `poses.py`) that the
master's link took: in a session with keys, only an operator's (nodes/master/link.py).

The controls are levels, so the latest message says all: paused or not, how many resets the
sender has asked for since it started (one more than the master last saw is a reset; fewer
is a new sender, whose count the master adopts), quit or not. Controls sent longer ago than
MAX_TRACKING_AGE (the preview went quiet) ask nothing: a run is not left paused by a window
that is gone. Each request names who sent it, for the run's record.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from cavesim.core.wire import TrackingMessage
from cavesim.core.wire.credentials import Identity
from cavesim.core.wire.payloads.poses import MAX_TRACKING_AGE


@dataclass(frozen=True)
class Controller:
    """The latest message with session controls the link took, and who signed it."""

    message: TrackingMessage
    sender: Identity | None = None  # None: a session without keys, where nobody signs


@dataclass(frozen=True)
class Asked:
    """One frame's requests, and who asked them."""

    paused: bool = False
    reset: bool = False
    quit: bool = False
    by: str | None = None  # the sender's identity ("operator preview"); None: unsigned


class UserRequests:
    def __init__(self) -> None:
        self.resets = 0  # the count the master last saw

    def take(self, latest: Controller | None, now_ns: int | None = None) -> Asked:
        """This frame's requests from `latest`, the newest message with controls."""
        if latest is None or latest.message.controls is None:
            return Asked()
        now_ns = time.time_ns() if now_ns is None else now_ns
        if abs(now_ns - latest.message.sent_ns) / 1e9 > MAX_TRACKING_AGE:
            return Asked()
        controls = latest.message.controls
        reset, self.resets = controls.resets > self.resets, controls.resets
        by = None if latest.sender is None else str(latest.sender)
        return Asked(controls.paused, reset, controls.quit, by)
