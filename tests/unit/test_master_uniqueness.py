"""One master per session, the master's side (nodes/master/process.py): another master's
token before the first frame makes it refuse to start, without a word to the nodes; once
it runs, it keeps its run and counts the other."""

from __future__ import annotations

from pathlib import Path

import pytest
from memory_walls import MemoryLink

from cavesim.core.errors import ClusterError
from nodes.master.events import OtherMaster
from nodes.master.process import MasterConfig, run_master

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
OTHER_RUN = 0xBEEF
KEY = f"cavesim/one/master_alive/{OTHER_RUN:016x}"


def config(frames: int = 10) -> MasterConfig:
    return MasterConfig(WALLS, MINIMAL, frames, session="one", barrier_timeout=1.0,
                        join_timeout=10.0)


def test_a_master_that_finds_another_before_its_first_frame_refuses_in_one_line():
    link = MemoryLink(WALLS)
    link.events.put(OtherMaster(OTHER_RUN, KEY))  # after the walls' liveliness, before joins
    with pytest.raises(ClusterError) as refused:
        run_master(config(), link)
    assert str(refused.value) == (f"another master's run {OTHER_RUN:016x} is on session one: "
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
