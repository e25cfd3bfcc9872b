"""One master per session, the master's side (nodes/master/process.py): waiting for its
walls, a master refuses to start beside one whose run started first, without a word to the
nodes; one that runs, or started first, keeps its run and counts the other. Of two that
meet, exactly one keeps the session."""

from __future__ import annotations

from pathlib import Path

import pytest
from memory_walls import MemoryLink

from cavesim.core.errors import ClusterError
from cavesim.core.wire.envelope import RUN_RANDOM_BITS, new_run_id, run_started
from nodes.master.events import OtherMaster
from nodes.master.process import MasterConfig, run_master

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
OTHER_RUN = 0xBEEF  # started in 1970: before any run of these tests
KEY = f"cavesim/one/master_alive/{OTHER_RUN:016x}"
STARTED_MS = 1_800_000_000_000  # a start time, in ms since the Unix epoch


def config(frames: int = 10) -> MasterConfig:
    return MasterConfig(WALLS, MINIMAL, frames, session="one", barrier_timeout=1.0,
                        join_timeout=10.0)


def test_a_master_that_finds_another_before_its_first_frame_refuses_in_one_line():
    link = MemoryLink(WALLS)
    link.run_id = new_run_id()  # started now, after the other
    link.events.put(OtherMaster(OTHER_RUN, KEY))  # after the walls' liveliness, before joins
    with pytest.raises(ClusterError) as refused:
        run_master(config(), link)
    assert str(refused.value) == (f"another master's run {OTHER_RUN:016x}, started first (at "
                                  f"1970-01-01 00:00:00.000 UTC), is on session one: "
                                  f"refusing to start run {link.run_id:016x}; stop that "
                                  f"master first")
    assert link.sent == []  # no WELCOME, no STOP: the nodes are the other master's


def test_a_running_master_keeps_its_run_and_counts_another():
    link = MemoryLink(WALLS)

    def another_master_comes(k: int) -> None:
        if k == 5:
            link.events.put(OtherMaster(OTHER_RUN, KEY))

    record = run_master(config(), link, before_frame=another_master_comes)
    assert record.frames == 10 and record.final.agree and record.final.members == WALLS
    assert record.master_rejected == {"other-master": 1}


@pytest.mark.parametrize("runs", [
    (new_run_id(STARTED_MS * 10**6), new_run_id((STARTED_MS + 1) * 10**6)),  # 1 ms apart
    (STARTED_MS << RUN_RANDOM_BITS | 5, STARTED_MS << RUN_RANDOM_BITS | 9),  # the same ms
], ids=["a-millisecond-apart", "in-the-same-millisecond"])
def test_of_two_masters_waiting_for_their_walls_exactly_one_keeps_the_session(runs):
    """Both wait for a wall that is late and hear of each other meanwhile: the one whose run
    started first (the smaller id) keeps waiting and runs; the other refuses in one line
    naming it, without a word to the nodes."""
    first, second = runs
    assert first < second

    def master(ours: int, other: int):
        link = MemoryLink(WALLS, late=("left",))
        link.run_id = ours
        link.events.put(OtherMaster(other, f"cavesim/one/master_alive/{other:016x}"))
        link.come_up("left")  # after the other's token: it came while this one waited
        try:
            return link, run_master(config(), link)
        except ClusterError as e:
            return link, e

    (_, kept), (refused_link, refused) = master(first, second), master(second, first)
    assert kept.frames == 10 and kept.final.agree
    assert kept.master_rejected == {"other-master": 1}
    assert isinstance(refused, ClusterError) and refused_link.sent == []
    assert str(refused) == (f"another master's run {first:016x}, started first (at "
                            f"{run_started(first)}), is on session one: refusing to start "
                            f"run {second:016x}; stop that master first")
