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
                  "second-master", "snapshot-collision", "oversize")
# the harness does them from outside: kill and restart a node, publish junk, replay signed
# traffic and an earlier run's messages, kill the master and start a new one, serve forged
# snapshots to a node it makes diverge, flood the nodes with junk and state queries, report
# in every other wall's name with one wall's key, replay the walls' own queries during a
# resync, replay an earlier run's tracking, start a second master beside the first, serve
# a state whose checksum collides with the named one, and send messages larger than the
# transport takes
KINDS = NODE_FAULTS + HARNESS_FAULTS
WHOLE_CLUSTER = ("rogue", "replay-attack", "master-kill", "flood", "report-forgery",
                 "tracking-replay", "second-master", "oversize")  # no node's: the others
# are done to one node (the last wall unless one is named)
FLOOD_MESSAGES, FLOOD_QUERIES = 200_000, 2_000  # a flood's junk messages and state queries
SETTLE = 30  # frames after an attack on the whole cluster before its effects are measured
# the harness makes these kinds' node diverge this many times, DIVERGENCE_GAP frames apart:
# a query replay captures the first resync's queries and replays them against the second's;
# a collision's forgers race the wall asked for its state, and win only now and then
DIVERGENCES = {"query-replay": 2, "snapshot-collision": 8}
DIVERGENCE_GAP = 10
EVERY_KIND_SPACING = 90  # frames between the faults of `every_kind`: past a collision's
# eight divergences and the measurements after them
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


def parse_fault(spec: str) -> Fault:
    """`bitflip@40:left` -> Fault("bitflip", 40, "left"); ValueError names what is allowed."""
    match = _SPEC.fullmatch(spec.strip())
    if not match or match["kind"] not in KINDS or int(match["frame"]) < 1:
        raise ValueError(f"fault {spec!r} must be KIND@FRAME[:NODE] with KIND one of "
                         f"{', '.join(KINDS)} and FRAME >= 1")
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
        raise ValueError(f"a fault of every kind needs --frames >= "
                         f"{(len(spread) + 2) * EVERY_KIND_SPACING}")
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
