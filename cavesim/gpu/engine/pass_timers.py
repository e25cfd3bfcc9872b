"""GPU time of a frame's passes: GL_TIME_ELAPSED queries around each, read after the
frame's fence (the results are in by then, so reading them waits for nothing).

Timing is sampled: only a frame the node arms (`armed`, every GPU_TIMED_EVERY frames) is
timed, since a timer query is not free everywhere (on llvmpipe the queries of one frame
cost about 0.13 ms of CPU, a quarter of a small scene's frame). A pass may be timed in
segments (the GS/TF particle pass is two draws with a read between them, which the timer
must not cover); a name's segments add up. The queries are made once; segments past the
pool's size start it over, so passes no one reads cost nothing.
"""

from __future__ import annotations

import contextlib

import moderngl

GPU_PASSES = ("emitter_pass", "particle_pass", "checksum_pass")
GPU_TIMED_EVERY = 16  # frames: one in this many is timed on the GPU
POOL = 8  # segments between two reads: a frame has at most five
_UNTIMED = contextlib.nullcontext()


class PassTimers:
    def __init__(self, ctx: moderngl.Context) -> None:
        self._pool = [ctx.query(time=True) for _ in range(POOL)]
        self._used: list[tuple[str, moderngl.Query]] = []
        self.armed = False  # whether the passes issued now are timed

    def segment(self, name: str) -> contextlib.AbstractContextManager:
        """What to time one segment of pass `name` with (`with timers.segment(...):`): a
        query when armed, else nothing."""
        if not self.armed:
            return _UNTIMED
        if len(self._used) == POOL:
            self._used.clear()
        query = self._pool[len(self._used)]
        self._used.append((name, query))
        return query

    def read_us(self) -> dict[str, int] | None:
        """Microseconds of each pass in GPU_PASSES since the last read (0: not run), after
        the GPU finished them; None when nothing was timed."""
        if not self._used:
            return None
        times = dict.fromkeys(GPU_PASSES, 0)
        for name, query in self._used:
            times[name] += query.elapsed // 1000
        self._used.clear()
        return times
