"""The master's decisions, as pure functions of what it knows: who is in, who is missing,
which checksum the cluster agrees on, whom to resync from whom.

No clock, no network, no GL: `nodes/master/process.py` feeds these with the typed events it
receives and carries out what they decide (publish, resync, record), so the rules of the
lock-step are tested on their own (tests/unit/test_lockstep.py).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from cavesim.core.wire import ReportMessage
from cavesim.core.wire.payloads.from_nodes import Status

LOSS_POLICIES = ("continue", "pause")  # drop a lost member and go on, or wait for it
MASTER_LOSS_POLICIES = ("wait", "exit")  # a node whose master is gone: wait for a new one, or exit
RESYNC_MODES = ("delta", "full")  # a node's resync: a delta first (else the full snapshot)
MASTER_GONE = "the master is gone"  # a node's log line says so (the harness looks for it)
NODE_UP = "up on EGL device"  # a node's log line once it listens and is announced (as well)


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
class CountDispute:
    """A member whose values of one counter are not the agreed ones (or, where no majority
    agreed, not those of the first member that counted it)."""

    node: str
    counter: int  # its id (cavesim/core/counters.py)
    values: tuple[int, ...]
    agreed: tuple[int, ...]


@dataclass(frozen=True)
class CountAgreement:
    """What the members holding one state agree their frame counted."""

    agreed: dict[int, tuple[int, ...]] = field(default_factory=dict)  # per counter id
    unagreed: tuple[int, ...] = ()  # counted, but not by a majority of two or more alike
    disputes: tuple[CountDispute, ...] = ()  # counts to resync for
    named: tuple[str, ...] = ()  # the disputed, and every counter of a split without majority


@dataclass(frozen=True)
class Vote:
    """The outcome of comparing one frame's checksums, and the counters of the agreed state."""

    agreed: str  # the digest the cluster keeps
    particles: int  # live particles of the agreed state
    source: str  # a member holding the agreed state (and counts)
    odd: tuple[str, ...] = ()  # members to resync to it
    named: tuple[str, ...] = ()  # members named in the divergence record
    counts: CountAgreement = CountAgreement()

    @property
    def diverged(self) -> bool:
        return bool(self.odd)


def vote(members: tuple[str, ...], reports: Mapping[str, ReportMessage],
         compare: bool = True, widths: Mapping[int, int] | None = None) -> Vote:
    """The checksum the members agree on: a strict majority's, else (two nodes, an even
    split) the first member's with every member named. `compare` False (a frame between
    two checks) takes the first member's without comparing.

    Every member holding the agreed state counted the same frame from the same state, so
    their counters of the run (`widths`: id -> number of values) must agree too
    (`agree_counts`): a member whose counts differ is odd, named and resynced like one whose
    checksum differs, and the source holds the agreed counts. Between two checks the counts
    are agreed all the same, but nobody is named."""
    widths = widths or {}
    first = reports[members[0]]
    alone = len(members) == 1
    if not compare:
        counts = agree_counts(members, reports, widths, alone)
        return Vote(first.digest, first.particles, members[0],
                    counts=replace(counts, disputes=(), named=()))
    digest, count = Counter(reports[m].digest for m in members).most_common(1)[0]
    majority = count * 2 > len(members)
    if not majority:
        digest = first.digest
    holders = tuple(m for m in members if reports[m].digest == digest)
    counts = agree_counts(holders, reports, widths, alone)
    disputed = {d.node for d in counts.disputes}
    source = next((m for m in holders if m not in disputed), holders[0])
    differ = tuple(m for m in members if reports[m].digest != digest)
    odd = tuple(m for m in members if (m in differ or m in disputed) and m != source)
    named_by_digest = (differ if majority else members) if differ else ()
    named = tuple(m for m in members if m in named_by_digest or m in counts.named)
    return Vote(digest, reports[source].particles, source, odd, named, counts)


def agree_counts(holders: tuple[str, ...], reports: Mapping[str, ReportMessage],
                 widths: Mapping[int, int], alone: bool = False) -> CountAgreement:
    """The counters `holders` (members holding one state, in member order) agree on. Per
    counter of the run (`widths`): the values a strict majority of the holders that counted
    it reported, where two or more did (`alone`: the lock-step has one member, whose word is
    all there is, as for its checksum); the holders that reported other values, or another
    number of values, are disputes. A holder that did not count a counter (its engine path
    cannot there) is not counted, not odd; ids outside `widths` are skipped (`skipped`)."""
    agreed: dict[int, tuple[int, ...]] = {}
    unagreed, disputes, named = [], [], []
    for id_, width in widths.items():
        held = [(m, values) for m in holders
                for counter, values in reports[m].counters if counter == id_]
        if not held:
            continue
        formed = [values for _, values in held if len(values) == width]
        values, alike = Counter(formed).most_common(1)[0] if formed else ((), 0)
        if alike * 2 > len(held) and (alike >= 2 or alone):
            agreed[id_] = values
        else:
            unagreed.append(id_)
            values = held[0][1]
            split = [m for m, v in held if v != values]
            named += [m for m, _ in held] if split else []
        disputes += [CountDispute(m, id_, v, values) for m, v in held if v != values]
    named += [d.node for d in disputes]
    return CountAgreement(agreed, tuple(unagreed), tuple(disputes),
                          tuple(m for m in holders if m in named))


def skipped_counters(members: tuple[str, ...], reports: Mapping[str, ReportMessage],
                     widths: Mapping[int, int]) -> dict[str, int]:
    """Per member, the counters its report carries that the run does not count (an id of a
    newer build, or of a feature the scene lacks): skipped, not an error, not a divergence."""
    return {m: skipped for m in members
            if (skipped := sum(id_ not in widths for id_, _ in reports[m].counters))}


def reported_counts(report: ReportMessage, widths: Mapping[int, int]) -> CountAgreement:
    """One member's counters as it reported them, those of the run and well formed (the
    mixed-hardware mode keeps the authority's: its walls' bits, and counts, may differ)."""
    return CountAgreement({id_: values for id_, values in report.counters
                           if widths.get(id_) == len(values)})


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
