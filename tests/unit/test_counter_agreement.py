"""Counters agreed, not trusted: every member holding the agreed state counted the same frame
from the same state, so the master compares their counters as it compares their checksums
(nodes/lockstep.py), and books only what they agree on. A wall that reports other counts
with its state's true checksum (an insider that lies) is named and resynced; a wall that
counts nothing for a row is not odd; an id the run does not count is counted and skipped;
the mixed-hardware mode keeps the authority's counts and says so. The pure rules first,
then the master's whole loop over walls in memory (tests/support/memory_walls.py)."""

from pathlib import Path

from memory_walls import MemoryLink

from cavesim.core.counters import BY_NAME
from cavesim.core.frame_cost import NO_COST
from cavesim.core.wire import ReportMessage
from nodes import lockstep
from nodes.faults import INFLATION
from nodes.master.process import MasterConfig, run_master
from nodes.master.tolerance import Tolerance

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")
EXITS, DROPS = BY_NAME["domain_exits"].id, BY_NAME["capacity_drops"].id
WIDTHS = {EXITS: 2, DROPS: 1}  # a scene of two classes with a grid and emitters
FRAMES = 30


def report(wall: str, counters=(), digest: str = "a") -> ReportMessage:
    return ReportMessage(1, wall, digest * 32, 10, 0, NO_COST, counters=counters)


def reports(**counters) -> dict[str, ReportMessage]:
    return {wall: report(wall, counted) for wall, counted in counters.items()}


HONEST = ((EXITS, (0, 3)), (DROPS, (5,)))


def test_members_that_agree_on_their_counters_are_not_odd():
    vote = lockstep.vote(WALLS, reports(front=HONEST, left=HONEST, right=HONEST), True, WIDTHS)
    assert not vote.diverged and vote.counts.agreed == {EXITS: (0, 3), DROPS: (5,)}


def test_a_member_whose_counters_differ_beside_the_agreed_checksum_is_named_and_resynced():
    lying = ((EXITS, (0, 3)), (DROPS, (5 + INFLATION,)))
    vote = lockstep.vote(WALLS, reports(front=lying, left=HONEST, right=HONEST), True, WIDTHS)
    assert vote.odd == vote.named == ("front",) and vote.source == "left"
    assert vote.counts.agreed == {EXITS: (0, 3), DROPS: (5,)}
    (dispute,) = vote.counts.disputes
    assert (dispute.node, dispute.counter, dispute.values, dispute.agreed) == (
        "front", DROPS, (5 + INFLATION,), (5,))


def test_a_member_that_counts_nothing_is_not_odd_and_one_alone_is_not_believed():
    counted = reports(front=HONEST, left=(), right=HONEST)
    vote = lockstep.vote(WALLS, counted, True, WIDTHS)
    assert not vote.diverged and vote.counts.agreed == dict(HONEST)
    alone = lockstep.vote(WALLS, reports(front=HONEST, left=(), right=()), True, WIDTHS)
    assert not alone.diverged and alone.counts.agreed == {}
    assert set(alone.counts.unagreed) == {EXITS, DROPS}, "one wall's word, unchecked"
    single = lockstep.vote(("front",), reports(front=HONEST), True, WIDTHS)
    assert single.counts.agreed == dict(HONEST), "a lock-step of one: its word is all there is"


def test_two_members_that_split_are_both_named_and_their_counts_not_booked():
    lying = ((EXITS, (0, 3)), (DROPS, (6,)))
    vote = lockstep.vote(("front", "left"), reports(front=HONEST, left=lying), True, WIDTHS)
    assert vote.named == ("front", "left") and vote.odd == ("left",)
    assert vote.counts.agreed == {EXITS: (0, 3)} and vote.counts.unagreed == (DROPS,)


def test_only_members_holding_the_agreed_state_are_compared():
    counted = reports(front=HONEST, left=HONEST, right=((DROPS, (INFLATION,)),))
    counted["right"] = report("right", ((DROPS, (INFLATION,)),), digest="b")
    vote = lockstep.vote(WALLS, counted, True, WIDTHS)
    assert vote.odd == ("right",) and vote.counts.disputes == ()
    assert vote.counts.agreed == dict(HONEST)


def test_a_wrong_number_of_values_is_disputed_and_unknown_ids_are_skipped_and_counted():
    wrong = ((EXITS, (0, 3, 0)), (DROPS, (5,)), (900, (1, 2)))
    counted = reports(front=HONEST, left=HONEST, right=wrong)
    vote = lockstep.vote(WALLS, counted, True, WIDTHS)
    assert vote.odd == ("right",) and vote.counts.agreed == dict(HONEST)
    assert lockstep.skipped_counters(WALLS, counted, WIDTHS) == {"right": 1}


def test_between_two_checks_the_counters_are_agreed_but_nobody_is_named():
    lying = ((DROPS, (INFLATION,)),)
    vote = lockstep.vote(WALLS, reports(front=lying, left=HONEST, right=HONEST), False, WIDTHS)
    assert not vote.diverged and not vote.named and vote.counts.agreed == dict(HONEST)


# -- the master's loop --------------------------------------------------------------------


def run(link: MemoryLink, **options):
    config = MasterConfig(tuple(link.walls), MINIMAL, FRAMES, "memory", barrier_timeout=1.0,
                          **options)
    return run_master(config, link)


def honest_drops(frames: int = FRAMES) -> int:
    return sum(k % 3 for k in range(1, frames + 1))  # what memory walls count


def test_an_insider_that_inflates_its_counts_is_named_resynced_and_not_believed():
    link = MemoryLink(WALLS, counting=True)
    link.walls["right"].inflate_at.update({7, 8})
    record = run(link)
    first, second = record.divergences
    assert (first.frame, first.nodes, second.frame) == (7, ("right",), 8)
    assert first.checksums["right"] == first.agreed, "its state was the agreed one"
    assert first.counters == {"right": {"capacity_drops": {"values": [1 + INFLATION],
                                                           "agreed": [1]}}}
    assert [(r.frame, r.node, r.source, r.ok) for r in record.resyncs] == [
        (7, "right", "front", True), (8, "right", "front", True)]
    drops = record.summary()["counters"]["capacity_drops"]
    assert drops["total"] == honest_drops() and drops["first_frame"] == 1
    assert drops["frames_not_counted"] == drops["frames_unagreed"] == 0
    assert record.final.agree


def test_the_first_member_inflating_leaves_the_others_as_source():
    link = MemoryLink(WALLS, counting=True)
    link.walls["front"].inflate_at.add(5)
    record = run(link)
    (divergence,) = record.divergences
    assert divergence.nodes == ("front",)
    assert [(r.node, r.source) for r in record.resyncs] == [("front", "left")]
    assert record.summary()["counters"]["capacity_drops"]["total"] == honest_drops()


def test_unknown_counters_are_counted_per_wall_and_skipped_and_a_silent_wall_is_no_fault():
    link = MemoryLink(WALLS, counting=True)
    link.walls["left"].unknown_counters = ((4242, (1, 2, 3)), (EXITS, (9, 9)))  # no grid
    link.walls["right"].counts_nothing = True
    record = run(link)
    assert not record.divergences and record.final.agree
    section = record.summary()["counters"]
    assert section["unknown_ids_skipped"] == {"left": 2 * FRAMES}
    assert section["capacity_drops"]["total"] == honest_drops()


def test_the_mixed_hardware_mode_keeps_the_authoritys_counts_and_says_so():
    link = MemoryLink(WALLS, sample=4, counting=True)
    link.walls["left"].inflate_at.add(5)  # not the authority: its counts are not kept
    record = run(link, tolerance=Tolerance("front", sample=4))
    section = record.summary()["counters"]
    assert section["values_from"] == "authority" and not record.divergences
    assert section["capacity_drops"]["total"] == honest_drops()
