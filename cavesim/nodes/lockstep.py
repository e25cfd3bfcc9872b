"""The master's decisions, as pure functions of what it knows: who is in, who is missing,
which checksum the cluster agrees on, whom to resync from whom.

No clock, no network, no GL: `cavesim/nodes/master.py` feeds these with the typed events it
receives and carries out what they decide (publish, resync, record), so the rules of the
lock-step are tested on their own (tests/test_lockstep.py).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, replace

from cavesim.core.wire import ReportMessage
from cavesim.core.wire.messages import Status

LOSS_POLICIES = ("continue", "pause")  # drop a lost member and go on, or wait for it


@dataclass(frozen=True)
class Membership:
    """Who is in the lock-step. `members` keep wall order; a member lost by liveliness is
    `lost` until a resync brings it back."""

    walls: tuple[str, ...]
    members: tuple[str, ...] = ()
    alive: frozenset[str] = frozenset()
    lost: frozenset[str] = frozenset()

    def came_up(self, wall: str) -> Membership:
        return replace(self, alive=self.alive | {wall}) if wall in self.walls else self

    def went_down(self, wall: str, policy: str) -> tuple[Membership, bool]:
        """The membership after `wall`'s liveliness token went away, and whether a member
        was lost (with "continue" it leaves the members; with "pause" the barrier waits)."""
        if wall not in self.walls:
            return self, False
        gone = replace(self, alive=self.alive - {wall})
        if wall not in self.members:
            return gone, False
        members = self.members if policy == "pause" else tuple(
            m for m in self.members if m != wall)
        return replace(gone, members=members, lost=self.lost | {wall}), True

    def all_up(self) -> bool:
        return set(self.walls) <= self.alive

    def started(self) -> Membership:
        """Every wall a member: the run begins."""
        return replace(self, members=self.walls)

    def joiners(self) -> tuple[str, ...]:
        """Walls that are up but not in the lock-step (late, or back after a loss)."""
        return tuple(w for w in self.walls if w in self.alive and w not in self.members)

    def admitted(self, wall: str) -> Membership:
        """`wall` resynced: a member again, in wall order, no longer lost."""
        members = tuple(w for w in self.walls if w in self.members or w == wall)
        return replace(self, members=members, lost=self.lost - {wall})

    def healed(self, wall: str) -> Membership:
        return replace(self, lost=self.lost - {wall})


def missing(members: tuple[str, ...], reported: Mapping[str, ReportMessage]) -> list[str]:
    """Members whose report of the frame is not in yet."""
    return [m for m in members if m not in reported]


def stall_resyncs(membership: Membership,
                  reported: Mapping[str, ReportMessage]) -> list[tuple[str, str]]:
    """After a barrier timeout: (node, source) for each missing member that was lost and is
    back (it can only return by loading a healthy member's state)."""
    healthy = [m for m in membership.members if m in reported]
    if not healthy:
        return []
    return [(node, healthy[0]) for node in missing(membership.members, reported)
            if node in membership.lost and node in membership.alive]


@dataclass(frozen=True)
class Vote:
    """The outcome of comparing one frame's checksums."""

    agreed: str  # the digest the cluster keeps
    particles: int  # live particles of the agreed state
    source: str  # a member holding the agreed state
    odd: tuple[str, ...] = ()  # members to resync to it
    named: tuple[str, ...] = ()  # members named in the divergence record

    @property
    def diverged(self) -> bool:
        return bool(self.odd)


def vote(members: tuple[str, ...], reports: Mapping[str, ReportMessage],
         compare: bool = True) -> Vote:
    """The checksum the members agree on: a strict majority's, else (two nodes, an even
    split) the first member's with every member named. `compare` False (a frame between
    two checks) takes the first member's without comparing."""
    first = reports[members[0]]
    if not compare:
        return Vote(first.digest, first.particles, members[0])
    digest, count = Counter(reports[m].digest for m in members).most_common(1)[0]
    majority = count * 2 > len(members)
    if not majority:
        digest = first.digest
    odd = tuple(m for m in members if reports[m].digest != digest)
    source = next(m for m in members if reports[m].digest == digest)
    named = (odd if majority else members) if odd else ()
    return Vote(digest, reports[source].particles, source, odd, named)


def agreeing_source(members: tuple[str, ...], reports: Mapping[str, ReportMessage],
                    digest: str) -> str:
    """A member whose report holds `digest` (to resync a joiner from)."""
    return next(m for m in members if reports[m].digest == digest)


def resync_outcome(report: ReportMessage | None, source: ReportMessage) -> bool | None:
    """Whether a resync healed the node (its RESYNCED report holds the source's checksum);
    None while its RESYNCED report is not in."""
    if report is None or report.status is not Status.RESYNCED:
        return None
    return report.digest == source.digest
