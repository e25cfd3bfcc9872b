"""The master's clock: which frames to send, each with the same fixed dt.

Fixed (default): one frame as soon as the previous one is through the barrier; simulated
time runs as fast as the cluster can. Real time: wall time is fed into an accumulator,
each tick counting at most `max_frame_time`, and the frames it holds are sent at the
fixed dt, at most `max_substeps` in a row; whatever a hitch adds beyond that is dropped,
so no hitch ever reaches the GPU as a huge dt. Each drop is logged, at most one line every
DROP_LOG_INTERVAL of the clock's time: a cluster slower than real time drops on every tick,
and the next line after a quiet interval says how many drops it folds in and the seconds
dropped in all (report.json's `clock_dropped_seconds`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

log = logging.getLogger("cavesim.clock")
MAX_DT = 0.1  # s: a frame longer than this is no animation any more
DROP_LOG_INTERVAL = 1.0  # s: at most one line about dropped time per interval


def check_dt(dt: float) -> float:
    """The configured fixed step; ValueError names what is allowed."""
    if not isinstance(dt, int | float) or not math.isfinite(dt) or not 0 < dt <= MAX_DT:
        raise ValueError(f"dt must be finite, > 0 and <= {MAX_DT} s, got dt={dt!r}")
    return float(dt)


@dataclass
class Clock:
    dt: float
    realtime: bool = False
    max_frame_time: float = 0.1  # s of wall time one tick may count
    max_substeps: int = 4  # frames sent back to back to catch up
    now: Callable[[], float] = time.monotonic
    sleep: Callable[[float], None] = time.sleep
    dropped_seconds: float = 0.0  # wall time given up to hitches
    _accumulator: float = field(default=0.0, repr=False)
    _last: float | None = field(default=None, repr=False)
    _logged_at: float | None = field(default=None, repr=False)  # the last line's time
    _folded: int = field(default=0, repr=False)  # drops since that line, not logged
    _folded_seconds: float = field(default=0.0, repr=False)

    def __post_init__(self) -> None:
        check_dt(self.dt)
        if not 0 < self.max_frame_time <= 10 or self.max_substeps < 1:
            raise ValueError(f"max_frame_time must be in (0, 10] s and max_substeps >= 1, "
                             f"got {self.max_frame_time!r} and {self.max_substeps!r}")

    def wait_for_frame(self) -> float:
        """Block until the next frame is due (real time); return its dt (always `dt`)."""
        if not self.realtime:
            return self.dt
        while True:
            self._tick()
            if self._accumulator >= self.dt * (1 - 1e-9):  # sums of floats fall just short
                self._accumulator -= self.dt
                return self.dt
            self.sleep(self.dt - self._accumulator)

    def _tick(self) -> None:
        now = self.now()
        if self._last is not None:
            elapsed = max(now - self._last, 0.0)
            if elapsed > self.max_frame_time:
                self._drop(now, elapsed - self.max_frame_time,
                           f"a hitch of {elapsed:.3f} s counted as {self.max_frame_time:.3f} s")
                elapsed = self.max_frame_time
            self._accumulator += elapsed
            owed = self.max_substeps * self.dt  # at most this many frames back to back
            if self._accumulator > owed:
                behind = self._accumulator - owed
                self._drop(now, behind, f"real-time clock {behind:.3f} s behind: dropped")
                self._accumulator = owed
        self._last = now

    def _drop(self, now: float, seconds: float, what: str) -> None:
        """Give up `seconds` of wall time; log `what` unless a line was written less than
        DROP_LOG_INTERVAL ago (then it is folded into the next line)."""
        self.dropped_seconds += seconds
        if self._logged_at is not None and now - self._logged_at < DROP_LOG_INTERVAL:
            self._folded += 1
            self._folded_seconds += seconds
            return
        folded = (f"; {self._folded} more drop(s) of {self._folded_seconds:.3f} s since the "
                  f"last line" if self._folded else "")
        log.warning("%s%s (%.3f s dropped in all)", what, folded, self.dropped_seconds)
        self._logged_at, self._folded, self._folded_seconds = now, 0, 0.0
