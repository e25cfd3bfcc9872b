"""The master's decisions, as pure functions of what it knows: who is in, who is missing,
which checksum the cluster agrees on, whom to resync from whom.

No clock, no network, no GL: `nodes/master/process.py` feeds these with the typed events it
receives and carries out what they decide (publish, resync, record), so the rules of the
lock-step are tested on their own (tests/unit/test_lockstep.py).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, replace

from cavesim.core.wire import ReportMessage
from cavesim.core.wire.payloads.from_nodes import Status

LOSS_POLICIES = ("continue", "pause")  # drop a lost member and go on, or wait for it
MASTER_LOSS_POLICIES = ("wait", "exit")  # a node whose master is gone: wait for a new one, or exit
RESYNC_MODES = ("delta", "full")  # a node's resync: a delta first (else the full snapshot)
MASTER_GONE = "the master is gone"  # a node's log line says so (the harness looks for it)


@dataclass(frozen=True)
class Membership:
    """Who is in the lock-step. `alive`: walls that joined this run and are up; `members`
    (wall order) step in the barrier; a member lost (by liveliness, or evicted by the
    barrier or by failed resyncs) is `lost` until a resync brings it back. `waiting`: walls
    that asked to enter (they joined, or they fell behind); `given_up`: walls whose resyncs
    failed too often, out until their node joins anew."""

    walls: tuple[str, ...]
    members: tuple[str, ...] = ()
    alive: frozenset[str] = frozenset()
    lost: frozenset[str] = frozenset()
    waiting: frozenset[str] = frozenset()
    given_up: frozenset[str] = frozenset()

    def came_up(self, wall: str) -> Membership:
        """`wall`'s node joined this run (a new process, or a node that started over)."""
        if wall not in self.walls:
            return self
        return replace(self, alive=self.alive | {wall}, waiting=self.waiting | {wall},
                       given_up=self.given_up - {wall})

    def fell_behind(self, wall: str) -> Membership:
        """`wall`'s node holds an older frame than the cluster: it asks to be resynced."""
        if wall not in self.alive or wall in self.given_up:
            return self
        return replace(self, waiting=self.waiting | {wall})

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
        return replace(self, members=self.walls, waiting=frozenset())

    def joiners(self) -> tuple[str, ...]:
        """Walls that are up and asked to enter but are not in the lock-step (late, back
        after a loss, or evicted and heard from again)."""
        return tuple(w for w in self.walls if w in self.alive and w in self.waiting
                     and w not in self.members)

    def admitted(self, wall: str) -> Membership:
        """`wall` resynced: a member again, in wall order, no longer lost."""
        members = tuple(w for w in self.walls if w in self.members or w == wall)
        return replace(self, members=members, lost=self.lost - {wall},
                       waiting=self.waiting - {wall})

    def evicted(self, wall: str) -> Membership:
        """A member dropped by the master (silent past the limit): lost, still up."""
        return replace(self, members=tuple(m for m in self.members if m != wall),
                       lost=self.lost | {wall}, waiting=self.waiting - {wall})

    def gave_up(self, wall: str) -> Membership:
        """`wall`'s resyncs failed too often: out (and lost) until its node joins anew."""
        return replace(self.evicted(wall), given_up=self.given_up | {wall})

    def healed(self, wall: str) -> Membership:
        return replace(self, lost=self.lost - {wall}, waiting=self.waiting - {wall})


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


def resync_outcome(report: ReportMessage | None, digest: str) -> bool | None:
    """Whether a resync healed the node (its RESYNCED report holds the named checksum);
    None while its RESYNCED report is not in."""
    if report is None or report.status is not Status.RESYNCED:
        return None
    return report.digest == digest
