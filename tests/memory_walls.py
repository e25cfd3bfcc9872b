"""Walls simulated in memory, behind the master's `Link`: the master's whole logic runs in
the test's process, without Zenoh, GL or child processes.

A wall's state is a digest chained over the frames it stepped (BLAKE2b of the previous
digest and the frame's inputs), so walls that step the same frames agree and a fault shows
as a different digest. Walls answer at once, by putting events in the master's queue.
With `sample`, each report carries a drift sample (the mixed-hardware mode): every sampled
particle sits at x = the wall's `offset`, which a nudge moves (and changes its bits).
"""

from __future__ import annotations

import hashlib
import queue
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from cavesim.core.drift import DriftSample, sample_size
from cavesim.core.wire import (
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
)
from cavesim.core.wire.messages import Phase, Status
from cavesim.core.wire.rejects import RejectCounter
from cavesim.nodes.events import Described, Displayed, Reported, WallDown, WallUp

START = "0" * 32


@dataclass
class MemoryWall:
    name: str
    digest: str = START
    done: int = 0
    up: bool = True
    flip_at: set[int] = field(default_factory=set)  # frames after which its state is wrong
    drop_once: set[int] = field(default_factory=set)  # frames it misses the first time
    displays: bool = False  # a swap-locked window: DRAWN after its report, SWAPPED on SWAP
    draws_late: set[int] = field(default_factory=set)  # frames whose DRAWN never comes
    swap_seconds: float = 0.0  # how long its swap takes (SWAPPED comes that much later)
    swap_hangs: set[int] = field(default_factory=set)  # frames whose SWAPPED never comes
    swaps: list[tuple[int, int]] = field(default_factory=list)  # (frame, time_ns)
    silent_from: int | None = None  # from this frame on it is up but never reports
    offset: float = 0.0  # m: x of every particle its drift samples hold
    nudge_at: dict[int, float] = field(default_factory=dict)  # frame -> m added to offset


class MemoryLink:
    def __init__(self, walls: tuple[str, ...], late: tuple[str, ...] = (),
                 displaying: tuple[str, ...] = (), sample: int = 0) -> None:
        self.events: queue.Queue = queue.Queue()
        self.walls = {name: MemoryWall(name, up=name not in late, displays=name in displaying)
                      for name in walls}
        self.sent: list = []
        self.sent_ns: list[int] = []  # when each of `sent` went out
        self.run_id = 0x5EED
        self.rejects = RejectCounter("memory")
        self.dropped = 0
        self.tracking = None
        self.resync_fails: set[str] = set()  # walls whose every resync fails
        self.sample = sample  # records of each report's drift sample (0: none)
        for wall in self.walls.values():
            if wall.up:
                self.events.put(WallUp(wall.name))

    def send(self, message: FrameMessage | ControlMessage) -> None:
        self.sent.append(message)
        self.sent_ns.append(time.monotonic_ns())
        if isinstance(message, FrameMessage):
            for wall in self.walls.values():
                self._step(wall, message)
        elif message.command is Command.WELCOME:
            self._report(self.walls[message.target], Status.JOINED)
        elif message.command is Command.RESYNC:
            target, source = self.walls[message.target], self.walls[message.source]
            if source.digest == message.digest and target.name not in self.resync_fails:
                target.digest, target.done = source.digest, source.done  # verified, loaded
                target.offset = source.offset
            self._report(target, Status.RESYNCED)  # a failed one reports the state it kept
        elif message.command is Command.SWAP:
            for wall in self.walls.values():
                if wall.up and wall.displays and wall.done == message.frame \
                        and message.frame not in wall.swap_hangs:
                    threading.Timer(wall.swap_seconds, self._swap, (wall, message.frame)).start()
        elif message.command is Command.STOP:
            for wall in self.walls.values():
                self.go_down(wall.name)

    def ask_info(self, wall: str) -> None:
        self.events.put(Described(InfoMessage(0, wall, 0, True, "memory", "tests", "none",
                                              swap_locked=self.walls[wall].displays)))

    def sender_hint(self, wall: str) -> str | None:
        return None

    def go_down(self, name: str) -> None:
        if self.walls[name].up:
            self.walls[name].up = False
            self.events.put(WallDown(name))

    def come_up(self, name: str) -> None:
        wall = self.walls[name]
        wall.up, wall.digest, wall.done = True, START, 0  # a new process: no state yet
        wall.offset = 0.0
        self.events.put(WallUp(name))

    def _step(self, wall: MemoryWall, message: FrameMessage) -> None:
        k = message.frame
        if not wall.up or k != wall.done + 1 or wall.silent_from is not None \
                and k >= wall.silent_from:
            return
        if k in wall.drop_once:
            wall.drop_once.discard(k)
            return
        chained = hashlib.blake2b(bytes.fromhex(wall.digest), digest_size=16)
        chained.update(message.inputs.random_transform.tobytes())
        chained.update(message.inputs.dt.tobytes())
        wall.digest, wall.done = chained.hexdigest(), k
        if k in wall.flip_at or k in wall.nudge_at:
            wall.digest = f"{int(wall.digest, 16) ^ 1:032x}"
            wall.offset += wall.nudge_at.get(k, 0.0)
        self._report(wall, Status.STEPPED)
        if wall.displays and k not in wall.draws_late:
            self._display(wall, Phase.DRAWN, time.monotonic_ns())

    def _swap(self, wall: MemoryWall, k: int) -> None:
        wall.swaps.append((k, time.monotonic_ns()))
        self.events.put(Displayed(DisplayMessage(k, wall.name, Phase.SWAPPED, wall.swaps[-1][1])))

    def _display(self, wall: MemoryWall, phase: Phase, time_ns: int) -> None:
        self.events.put(Displayed(DisplayMessage(wall.done, wall.name, phase, time_ns)))

    def _report(self, wall: MemoryWall, status: Status) -> None:
        self.events.put(Reported(ReportMessage(wall.done, wall.name, wall.digest, wall.done,
                                               0, 0, 0, status=status,
                                               sample=self._sample(wall))))

    def _sample(self, wall: MemoryWall) -> DriftSample | None:
        if not self.sample:
            return None
        positions = np.zeros((sample_size(self.sample, wall.done), 3))
        positions[:, 0] = wall.offset
        return DriftSample.of(positions, np.zeros_like(positions))
