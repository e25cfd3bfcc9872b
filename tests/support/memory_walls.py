"""Walls simulated in memory, behind the master's `Link`: the master's whole logic runs in
the test's process, without Zenoh, GL or child processes.

A wall's state is a digest chained over the frames it stepped (BLAKE2b of the previous
digest and the frame's inputs), so walls that step the same frames agree and a fault shows
as a different digest. Or, with `particles`, real particle and emitter records stepped by a
small float32 rule, whose digest is the GPU checksum's numpy twin: such walls answer the
master's block questions as a node does (desync forensics), and a bit flip is a real one.
With `sample`, each report carries a drift sample (the mixed-hardware mode): every sampled
particle sits at x = the wall's `offset`, which a nudge moves (and changes its bits).
A wall may report a frame late: its report carries the time the link would have taken it,
that many seconds after the others' (a straggler, without a sleep).
With `counting`, each report of a frame k it stepped carries the minimal scene's one counter,
capacity_drops = k % 3, as an honest wall counts it; a wall may inflate it (an insider that
lies with its state's true digest), count nothing, or add counters the run does not know.
Walls answer at once, by putting events in the master's queue.
"""

from __future__ import annotations

import hashlib
import queue
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cavesim.core.counters import BY_NAME
from cavesim.core.digest.history import HistoryRing
from cavesim.core.digest.shape import EMITTERS
from cavesim.core.digest.twin import reference_checksum, reference_levels
from cavesim.core.drift import DriftSample, sample_size
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_DTYPE
from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.wire import (
    BlockReply,
    BlockRequest,
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
)
from cavesim.core.wire.envelope import decode, encode
from cavesim.core.wire.payloads.from_nodes import Phase, Status
from cavesim.core.wire.rejects import RejectCounter
from nodes.blocks import answer, check_reply
from nodes.faults import BitFlip, inflated
from nodes.master.events import Described, Displayed, Reported, WallDown, WallUp

START = "0" * 32
MEMORY_COST = tuple(1000 * (i + 1) for i in range(len(PHASES)))  # us: phase i takes i + 1 ms
MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"


class RecordState:
    """Particle and emitter records of a wall in memory, with the tree and history a node
    keeps (a `TreeHolder`)."""

    def __init__(self, particles: int, seed: int = 11) -> None:
        rng = np.random.default_rng(seed)
        self.particles = np.zeros(particles, PARTICLE_DTYPE)
        self.particles["pos"] = rng.uniform(-3, 3, (particles, 3))
        self.particles["vel"] = rng.uniform(-1, 1, (particles, 3))
        self.particles["lifetime"] = 100.0
        self.emitters = np.zeros(3, EMITTER_DTYPE)
        self.seed = seed
        self.ring = HistoryRing()
        self.kept: dict[int, np.ndarray] = {}  # slot -> fold-1 items

    def copy_of(self, other: RecordState) -> None:
        self.particles, self.emitters = other.particles.copy(), other.emitters.copy()
        self.seed = other.seed

    def step(self, dt: np.float32) -> None:
        self.particles["pos"] += self.particles["vel"] * dt
        self.particles["age"] += np.float64(dt)
        self.emitters["serial"] += 1

    def flip(self, flip: BitFlip) -> None:
        words = self.particles.view(np.uint32).reshape(len(self.particles), -1)
        words[flip.particle, flip.word] ^= np.uint32(1 << flip.bit)

    @property
    def digest(self) -> str:
        return reference_checksum(self._words(0), self._words(1), self.seed).digest

    def keep(self, frame: int) -> None:
        slot = self.ring.keep(frame, len(self.particles), len(self.emitters))
        self.kept[slot] = reference_levels(*self._words())[1]

    def _words(self, stream: int | None = None):
        words = (self.particles.view(np.uint32), self.emitters.view(np.uint32))
        return words if stream is None else words[stream]

    # -- TreeHolder ----------------------------------------------------------------------

    def tree_state(self) -> tuple[int, int, int]:
        return self.seed, len(self.particles), len(self.emitters)

    def tree_items(self, level: int, indices: np.ndarray) -> np.ndarray:
        return reference_levels(*self._words())[level][indices]

    def read_records(self, stream: int, indices: np.ndarray) -> bytes:
        return (self.emitters if stream == EMITTERS else self.particles)[indices].tobytes()

    def history(self, indices: np.ndarray, up_to: int):
        width = max(len(items) for items in self.kept.values())
        padded = {slot: np.vstack([items, np.zeros((width - len(items), 4), np.uint32)])
                  for slot, items in self.kept.items()}
        return [(entry, padded[entry.slot][indices]) for entry in self.ring.up_to(up_to)]


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
    unsampled_at: set[int] = field(default_factory=set)  # frames reported without a sample
    scene: str | None = None  # the digest its info names (None: the link's scene's)
    records: RecordState | None = None  # real records (the link's `particles`)
    flip_bits: dict[int, BitFlip] = field(default_factory=dict)  # frame -> a bit it flips
    inflate_at: set[int] = field(default_factory=set)  # frames whose counters it inflates
    counts_nothing: bool = False  # its engine path cannot count here: it reports none
    unknown_counters: tuple = ()  # (id, values) entries of counters the run does not know
    planted: bool = False  # it loaded a colliding state: its next frame differs
    late: dict[int, float] = field(default_factory=dict)  # frame -> s its report comes late


class MemoryLink:
    def __init__(self, walls: tuple[str, ...], late: tuple[str, ...] = (),
                 displaying: tuple[str, ...] = (), particles: int = 0, sample: int = 0,
                 scene: Path = MINIMAL, counting: bool = False) -> None:
        self.events: queue.Queue = queue.Queue()
        self.scene = scene_digest(load_scene(scene))  # the one the walls hold
        self.walls = {name: MemoryWall(name, up=name not in late, displays=name in displaying,
                                       records=RecordState(particles) if particles else None)
                      for name in walls}
        for wall in self.walls.values():
            if wall.records is not None:
                wall.digest = wall.records.digest
        self.sent: list = []
        self.sent_ns: list[int] = []  # when each of `sent` went out
        self.run_id = 0x5EED
        self.rejects = RejectCounter("memory")
        self.dropped = 0
        self.tracking = None
        self.controller = None  # the latest session controls (a preview's)
        self.resync_fails: set[str] = set()  # walls whose every resync fails
        # walls that, as a resync's source, serve a state built to collide with the named
        # checksum (insiders): refused where a confirmer is named, else loaded, and then the
        # node that loaded it diverges at its next frame
        self.colliding: set[str] = set()
        self.sample = sample  # records of each report's drift sample (0: none)
        self.counting = counting  # reports carry the frame's counters
        self.block_questions: list[BlockRequest] = []  # answered, in order
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
            refused = source.name in self.colliding and message.confirmer
            if source.digest == message.digest and target.name not in self.resync_fails \
                    and not refused:
                target.digest, target.done = source.digest, source.done  # verified, loaded
                target.planted = source.name in self.colliding
                if target.records is not None:
                    target.records.copy_of(source.records)
                    target.records.keep(target.done)
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
        held = self.walls[wall]
        self.events.put(Described(InfoMessage(0, wall, 0, True, "memory", "tests", "none",
                                              swap_locked=held.displays,
                                              scene=held.scene or self.scene)))

    def sender_hint(self, wall: str) -> str | None:
        return None

    def ask_blocks(self, wall: str, request: BlockRequest) -> BlockReply | None:
        """As a node answers: about the state it holds, through the wire's encoding."""
        held = self.walls[wall]
        if held.records is None or (held.done, held.digest) != (request.frame, request.digest):
            return None
        asked = decode(encode(request, "memory"), "memory")
        try:
            reply = answer(held.records, asked, wall)
        except ProtocolError:
            return None
        self.block_questions.append(request)
        return check_reply(decode(encode(reply, "memory"), "memory"), request)

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
        if wall.records is not None:
            wall.records.step(message.inputs.dt)
            if k in wall.flip_bits:
                wall.records.flip(wall.flip_bits[k])
            wall.digest, wall.done = wall.records.digest, k
            wall.records.keep(k)
        else:
            chained = hashlib.blake2b(bytes.fromhex(wall.digest), digest_size=16)
            chained.update(message.inputs.random_transform.tobytes())
            chained.update(message.inputs.dt.tobytes())
            wall.digest, wall.done = chained.hexdigest(), k
        if k in wall.flip_at or k in wall.nudge_at or wall.planted:
            wall.planted = False
            wall.digest = f"{int(wall.digest, 16) ^ 1:032x}"
            wall.offset += wall.nudge_at.get(k, 0.0)
        self._report(wall, Status.STEPPED, self._counters(wall))
        if wall.displays and k not in wall.draws_late:
            self._display(wall, Phase.DRAWN, time.monotonic_ns())

    def _swap(self, wall: MemoryWall, k: int) -> None:
        wall.swaps.append((k, time.monotonic_ns()))
        self.events.put(Displayed(DisplayMessage(k, wall.name, Phase.SWAPPED, wall.swaps[-1][1])))

    def _display(self, wall: MemoryWall, phase: Phase, time_ns: int) -> None:
        self.events.put(Displayed(DisplayMessage(wall.done, wall.name, phase, time_ns)))

    def _report(self, wall: MemoryWall, status: Status, counters: tuple = ()) -> None:
        particles = wall.done if wall.records is None else len(wall.records.particles)
        self.events.put(Reported(ReportMessage(wall.done, wall.name, wall.digest, particles,
                                               0, MEMORY_COST, status=status,
                                               sample=self._sample(wall), counters=counters),
                                 time.monotonic() + wall.late.get(wall.done, 0.0)))

    def _counters(self, wall: MemoryWall) -> tuple:
        """The counters of the frame `wall` just stepped, as its report carries them."""
        if not self.counting or wall.counts_nothing:
            return ()
        counted = ((BY_NAME["capacity_drops"].id, (wall.done % 3,)),)
        if wall.done in wall.inflate_at:
            counted = inflated(counted)
        return counted + tuple(wall.unknown_counters)

    def _sample(self, wall: MemoryWall) -> DriftSample | None:
        if not self.sample or wall.done in wall.unsampled_at:
            return None
        positions = np.zeros((sample_size(self.sample, wall.done), 3))
        positions[:, 0] = wall.offset
        return DriftSample.of(positions, np.zeros_like(positions))
