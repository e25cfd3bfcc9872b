"""The harness measures an attack's effect on the nodes twice (nodes/check/harness.py): the
second time not at a fixed number of frames after it, which a busy machine may not fill,
but once the nodes' reports say they counted what it sent (the last frame at most)."""

from __future__ import annotations

from pathlib import Path

from cavesim.core.wire.credentials import generate
from nodes.check.harness import _each_refused, _Harness
from nodes.faults import Fault
from nodes.master.process import MasterConfig

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
FRAMES = 100


def harness_counting(refused: list[dict[str, int]]) -> _Harness:
    """A harness whose measurements of the nodes find `refused` in turn (and then the last
    one again)."""
    harness = _Harness((), (), MasterConfig(WALLS, MINIMAL, FRAMES, credentials=generate()))
    harness._measure = lambda cluster: {"refused": refused.pop(0) if len(refused) > 1
                                        else refused[0]}
    return harness


def test_the_second_measurement_waits_until_every_node_counted_the_attack():
    harness = harness_counting([{"front": 5, "left": 7},  # at the attack
                                {"front": 6, "left": 7},  # frames 50, 51: left has not
                                {"front": 6, "left": 7},
                                {"front": 6, "left": 8}])  # frame 52: both have
    measured = harness._measure_from(Fault("oversize", 20), None, 50, _each_refused(1))
    for k in range(21, FRAMES + 1):
        harness.before_frame(None, k)
    assert measured["until"] == 52 and measured["after"]["refused"] == {"front": 6, "left": 8}


def test_what_is_never_counted_is_measured_at_the_last_frame():
    harness = harness_counting([{"front": 5, "left": 7}])
    measured = harness._measure_from(Fault("oversize", 20), None, 50, _each_refused(1))
    for k in range(21, FRAMES + 1):
        harness.before_frame(None, k)
    assert measured["until"] == FRAMES and measured["after"]["refused"] == {"front": 5,
                                                                            "left": 7}


def test_without_a_count_to_wait_for_it_measures_at_the_frame_planned():
    harness = harness_counting([{"front": 5, "left": 7}])
    measured = harness._measure_from(Fault("flood", 20), None, 50)
    for k in range(21, FRAMES + 1):
        harness.before_frame(None, k)
    assert measured["until"] == 50 and "after" in measured
