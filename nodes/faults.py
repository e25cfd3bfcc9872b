"""Faults the consistency harness injects: `KIND@FRAME[:NODE]`."""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass

from cavesim.core.records import PARTICLE_WORDS

NODE_FAULTS = ("bitflip", "seed", "drop", "stale", "slow", "jitter", "shove", "inflate",
               "straggler")
# the node does them to itself; jitter and shove make it drift, as another GPU's rounding
# would and far beyond any tolerance (nodes/wall/drift_sample.py); inflate reports counters
# far above what it counted, with its state's true checksum (an insider that lies); slow
# holds one frame's report, a straggler every frame's from its own on
HARNESS_FAULTS = ("kill", "rogue", "replay-attack", "master-kill", "snapshot-forgery",
                  "flood", "report-forgery", "query-replay", "tracking-replay",
                  "second-master", "snapshot-collision", "oversize", "colliding-source",
                  "control-forgery", "count-forgery")
# the harness does them from outside: kill and restart a node, publish junk, replay signed
# traffic and an earlier run's messages, kill the master and start a new one, serve forged
# snapshots to a node it makes diverge, flood the nodes with junk and state queries, report
# in every other wall's name with one wall's key, replay the walls' own queries during a
# resync, replay an earlier run's tracking, start a second master beside the first, serve
# a state whose checksum collides with the named one (under another wall's key, or as the
# resync's source itself), send messages larger than the transport takes, pause, reset
# and stop the run with one wall's key, and report a node's frame with its stolen key,
# the real checksum and counts far above the real ones (nodes/check/count_forgery.py)
KINDS = NODE_FAULTS + HARNESS_FAULTS
NODE_PARTS = ("withhold",)  # what a node does for the harness's attacks, no fault of its
# own: at `withhold@K` it does not answer the first state query of frame K (the resync's
# first query then finds only a forger's twin: the attack is shown every time)
WHOLE_CLUSTER = ("rogue", "replay-attack", "master-kill", "flood", "report-forgery",
                 "tracking-replay", "second-master", "oversize", "control-forgery")
# no node's: the others are done to one node (the last wall unless one is named)
CONTROL_REQUESTS = ("pause", "reset", "stop")  # what a control-forgery asks, one a frame
FLOOD_MESSAGES, FLOOD_QUERIES = 200_000, 2_000  # a flood's junk messages and state queries
SETTLE = 30  # frames after an attack on the whole cluster before its effects are measured
RESYNCED = 5  # frames after a forged state's last divergence before the node is measured
COLLISIONS = ("snapshot-collision", "colliding-source")  # a state with the named checksum
# served to a node's resync: the wall that holds the state besides the source and the node
# makes it (and confirms the resync), so these need MIN_COLLISION_WALLS
MIN_COLLISION_WALLS = 3
DIVERGING = ("snapshot-forgery", "query-replay", *COLLISIONS)  # the harness makes their
# node diverge (a bitflip) for them, at `divergence_frames`
# the harness makes these kinds' node diverge this many times (else once), DIVERGENCE_GAP
# frames apart: a query replay captures the first resync's queries and replays them against
# the second's; a colliding source's twin is refused each time
DIVERGENCES = {"query-replay": 2, "colliding-source": 2}
DIVERGENCE_GAP = 10
EVERY_KIND_SPACING = 71  # frames between the faults of `every_kind`: past the slowest
# kind's effects and the measurements after them (a flood's and an oversize's SETTLE frames)
FLIPPED_BIT = 20  # of the word a bitflip changes: a mantissa bit of a float32 field
SLOW_DELAY = 1.5  # s a `slow` fault holds a report back (tests use a shorter barrier)
STRAGGLE_DELAY = 2.0  # s a `straggler` adds to each frame: twice the master's --max-lag
# the harness restarts a straggler's node this many frames after its fault: past the lags
# that give it up (the lag budget's 5 and one) and the frames the others' rate is measured
# over once it is out; the new process, without the fault, joins anew
STRAGGLER_RESTART = 30
CHECK_MAX_LAG = 0.25  # s, the harness's --max-lag: half its barrier timeout, as the master's
STRAGGLE_FACTOR = 2  # the harness's straggler takes this many times --max-lag more a frame
RATE_FRAMES = 20  # frames before a straggler's fault over which the others' rate is measured
_SPEC = re.compile(r"(?P<kind>[a-z-]+)@(?P<frame>\d+)(?::(?P<node>[A-Za-z0-9_-]+))?")


@dataclass(frozen=True)
class Fault:
    kind: str
    frame: int
    node: str | None = None

    def __str__(self) -> str:
        return f"{self.kind}@{self.frame}" + (f":{self.node}" if self.node else "")


def parse_fault(spec: str, kinds: tuple[str, ...] = KINDS) -> Fault:
    """`bitflip@40:left` -> Fault("bitflip", 40, "left"); ValueError names what is allowed
    (`kinds`: a node also takes NODE_PARTS)."""
    match = _SPEC.fullmatch(spec.strip())
    if not match or match["kind"] not in kinds or int(match["frame"]) < 1:
        raise ValueError(f"fault {spec!r} must be KIND@FRAME[:NODE] with KIND one of "
                         f"{', '.join(kinds)} and FRAME >= 1")
    return Fault(match["kind"], int(match["frame"]), match["node"])


def divergence_frames(fault: Fault) -> tuple[int, ...]:
    """The frames at which the harness makes the node of `fault` diverge for it."""
    return tuple(fault.frame + i * DIVERGENCE_GAP
                 for i in range(DIVERGENCES.get(fault.kind, 1)))


def last_action(fault: Fault) -> int:
    """The last frame at which the harness acts for `fault`: its last divergence, or the
    restart of a straggler's node."""
    if fault.kind == "straggler":
        return fault.frame + STRAGGLER_RESTART
    return divergence_frames(fault)[-1]


def every_kind(frames: int, walls: tuple[str, ...]) -> tuple[Fault, ...]:
    """A fault of every kind in `frames` frames: `seed` at frame 1, the others spread evenly
    (each node's in turn over `walls`), and `master-kill` last, so that every node's fault
    comes before it. ValueError when the frames cannot keep them EVERY_KIND_SPACING apart."""
    spread = [kind for kind in KINDS if kind not in ("seed", "master-kill")]
    gap = frames // (len(spread) + 2)  # the last gap is the new master's run
    if gap < EVERY_KIND_SPACING:
        raise ValueError(f"a fault of each of the {len(KINDS)} kinds, {EVERY_KIND_SPACING} "
                         f"frames apart and the new master's run after the last, needs "
                         f"--frames >= {(len(spread) + 2) * EVERY_KIND_SPACING}, got {frames}")
    if len(walls) < MIN_COLLISION_WALLS:
        raise ValueError(f"a fault of every kind needs at least {MIN_COLLISION_WALLS} walls "
                         f"({', '.join(COLLISIONS)} need a second healthy wall), got "
                         f"{len(walls)}")
    faults, nodes = [Fault("seed", 1, walls[0])], itertools.cycle(walls)
    for slot, kind in enumerate(spread, start=1):
        faults.append(Fault(kind, slot * gap, None if kind in WHOLE_CLUSTER else next(nodes)))
    return (*faults, Fault("master-kill", (len(spread) + 1) * gap))


@dataclass(frozen=True)
class BitFlip:
    """Where a `bitflip` fault flips a bit: `bit` of 32-bit word `word` of particle record
    `particle`."""

    particle: int
    word: int
    bit: int


def bitflip_target(live: int) -> BitFlip:
    """The bit a `bitflip` flips in a stream of `live` particles: bit FLIPPED_BIT of the
    stream's middle word. A function of the live count alone, so that the harness knows it
    (and can check that the forensics name exactly it)."""
    if live < 1:
        raise ValueError(f"a bitflip needs a live particle, got {live=}")
    word = live * PARTICLE_WORDS // 2
    return BitFlip(word // PARTICLE_WORDS, word % PARTICLE_WORDS, FLIPPED_BIT)


INFLATION = 1_000_000  # what an `inflate` fault adds to each value a node counted


def inflated(counters: tuple[tuple[int, tuple[int, ...]], ...]
             ) -> tuple[tuple[int, tuple[int, ...]], ...]:
    """A report's counter tail with every value INFLATION higher (within a uint)."""
    return tuple((id_, tuple(min(v + INFLATION, 2**32 - 1) for v in values))
                 for id_, values in counters)
