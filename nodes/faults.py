"""Faults the consistency harness injects: `KIND@FRAME[:NODE]`."""

from __future__ import annotations

import re
from dataclasses import dataclass

from cavesim.core.records import PARTICLE_WORDS

NODE_FAULTS = ("bitflip", "seed", "drop", "stale", "slow", "jitter", "shove")
# the node does them to itself; jitter and shove make it drift, as another GPU's rounding
# would and far beyond any tolerance (nodes/wall/drift_sample.py)
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
FLOOD_MESSAGES, FLOOD_QUERIES = 200_000, 2_000  # a flood's junk messages and state queries
# the harness makes these kinds' node diverge this many times, DIVERGENCE_GAP frames apart:
# a query replay captures the first resync's queries and replays them against the second's;
# a collision's forgers race the wall asked for its state, and win only now and then
DIVERGENCES = {"query-replay": 2, "snapshot-collision": 8}
DIVERGENCE_GAP = 10
FLIPPED_BIT = 20  # of the word a bitflip changes: a mantissa bit of a float32 field
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
