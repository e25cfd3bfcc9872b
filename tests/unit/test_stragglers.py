"""Stragglers and budgets: the lag and budget bookkeeping with the times given (no clock, no
sleep), and the master's whole loop over walls in memory (tests/support/memory_walls.py)
whose reports carry the time they came: a wall that lags every frame is named and given up
within the lag budget and the others go on, one late frame is not, and in the bit-exact
mode a wall that diverges every frame is given up within the breach budget."""

from pathlib import Path

import pytest
from memory_walls import MemoryLink

from cavesim.core.bounded import FirstEntries
from nodes import cli
from nodes.arguments import USAGE_ERROR
from nodes.budget_flags import limits_from
from nodes.commands.run import RunPlan
from nodes.master.budgets import BREACH, BUDGETS, LAG, WINDOW, Budget, Tally
from nodes.master.process import MasterConfig, run_master
from nodes.master.stragglers import DEFAULT_MAX_LAG, FrameArrivals, Stragglers

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")


# -- one frame's arrivals -----------------------------------------------------------------

@pytest.mark.parametrize("members, times, half", [
    (("a",), {"a": 5.0}, 5.0),
    (("a", "b"), {"b": 2.0, "a": 3.0}, 2.0),  # the first of two
    (("a", "b", "c"), {"a": 1.0, "b": 4.0, "c": 2.0}, 2.0),  # the second of three
    (("a", "b", "c", "d"), {"a": 1.0, "b": 9.0, "c": 2.0, "d": 3.0}, 2.0),  # of four
    (("a", "b", "c"), {"a": 1.0}, None),  # not half in yet
])
def test_half_the_members_are_in_at_the_lower_median_of_their_reports(members, times, half):
    arrivals = FrameArrivals(7, members)
    for node, at in times.items():
        arrivals.reported(node, at)
    assert arrivals.half_in() == half


def test_a_lag_is_measured_from_half_in_to_the_first_report_or_the_end():
    arrivals = FrameArrivals(7, WALLS)
    arrivals.reported("front", 10.0)
    arrivals.reported("left", 10.2)
    arrivals.reported("left", 10.05)  # a repeated report: the first one counts
    arrivals.reported("elsewhere", 10.0)  # not a member of the frame
    lags = arrivals.lags(1.0, now=12.0, alive=WALLS)  # right never reported: lagged until 12
    assert [(lag.frame, lag.node, round(lag.seconds, 6)) for lag in lags] == [(7, "right", 1.8)]
    arrivals.reported("right", 11.1)  # now it did: 0.9 s after half were in
    assert [(lag.node, round(lag.seconds, 6)) for lag in arrivals.lags(0.5, 12.0, WALLS)] \
        == [("right", 0.9)]
    assert arrivals.lags(1.0, 12.0, WALLS) == []  # within the bound


def test_one_member_never_lags_and_a_member_whose_node_went_does_not_either():
    alone = FrameArrivals(3, ("front",))
    alone.reported("front", 100.0)
    assert alone.lags(0.001, 200.0, ("front",)) == []
    arrivals = FrameArrivals(3, WALLS)
    arrivals.reported("front", 1.0)
    arrivals.reported("left", 1.0)
    assert arrivals.lags(0.1, 9.0, alive=("front", "left")) == []  # right's node is gone


# -- the budget -----------------------------------------------------------------------------

def test_the_event_one_past_the_budget_gives_the_wall_up_and_its_count_starts_over():
    tally = Tally(LAG, Budget(3, 100), "lagged")
    assert [tally.over(k, "left") for k in (10, 11, 12, 13)] == [False, False, False, True]
    assert tally.over(20, "right") is False  # each wall its own count
    assert [tally.over(k, "left") for k in (14, 15, 16)] == [False, False, False]
    assert tally.summary() == {"most": 3, "window_frames": 100, "given_up_total": 1,
                               "given_up": [{"frame": 13, "node": "left", "events": 4,
                                             "window_frames": 100}]}


def test_events_further_apart_than_the_window_stay_within_the_budget():
    tally = Tally(BREACH, Budget(1, 10), "diverged")
    assert [tally.over(k, "left") for k in (3, 13, 23, 33)] == [False] * 4
    assert tally.over(34, "left") is True  # 33 and 34 within 10 frames


@pytest.mark.parametrize("most, window", [(0, 600), (10_001, 600), (5, 0)])
def test_a_budget_out_of_range_is_refused(most, window):
    with pytest.raises(ValueError, match="budget"):
        Budget(most, window)


def test_the_stragglers_name_each_lag_and_give_up_the_one_past_the_budget():
    named = FirstEntries()
    stragglers = Stragglers(0.25, Budget(2, WINDOW), named)
    over = []
    for k in range(1, 5):  # left reports 0.5 s after the others, every frame
        stragglers.begin(k, WALLS)
        for node, at in (("front", k), ("right", k + 0.01), ("left", k + 0.51)):
            stragglers.reported(node, at)
        over.append(stragglers.end(k + 0.6, WALLS))
    assert over == [[], [], ["left"], []]  # the third lag is one past the budget of 2
    assert [(lag.frame, lag.node) for lag in named] == [(k, "left") for k in range(1, 5)]
    assert named[0].to_json() == {"frame": 1, "node": "left", "seconds": 0.5}
    with pytest.raises(ValueError, match="max_lag"):
        Stragglers(0.0, BUDGETS[LAG], FirstEntries())


# -- the master's loop in this process ------------------------------------------------------

def run(link, frames=30, **options):
    config = MasterConfig(tuple(link.walls), MINIMAL, frames, "memory", barrier_timeout=1.0,
                          **options)
    return run_master(config, link)


def test_a_wall_that_lags_every_frame_is_named_and_given_up_and_the_others_go_on():
    link = MemoryLink(WALLS)
    link.walls["left"].late.update({k: 1.9 for k in range(5, 31)})  # finding: 1.9 s a frame
    record = run(link)
    lags = [(lag.frame, lag.node, round(lag.seconds, 1)) for lag in record.lags]
    most = BUDGETS[LAG].most
    assert lags == [(k, "left", 1.9) for k in range(5, 5 + most + 1)]  # named every frame
    (loss,) = record.losses
    assert (loss.frame, loss.node, loss.detected_by) == (5 + most, "left", LAG)
    assert record.frames == 30 and record.final.lost == ("left",) and record.final.agree
    summary = record.summary()
    assert summary["max_lag_seconds"] == DEFAULT_MAX_LAG
    assert summary["lags"][0] == {"frame": 5, "node": "left", "seconds": pytest.approx(1.9)}
    assert summary["budgets"][LAG]["given_up"] == [
        {"frame": 5 + most, "node": "left", "events": most + 1, "window_frames": WINDOW}]
    assert summary["event_totals"]["lags"] == most + 1


def test_a_wall_late_once_is_named_but_stays_in():
    link = MemoryLink(WALLS)
    link.walls["right"].late[12] = 1.5  # a `slow` frame
    record = run(link)
    assert [(lag.frame, lag.node) for lag in record.lags] == [(12, "right")]
    assert not record.losses and record.final.all_walls_in and record.final.agree


def test_in_the_bit_exact_mode_a_wall_that_diverges_every_frame_is_given_up():
    link = MemoryLink(WALLS)
    link.walls["left"].flip_at.update(range(3, 400))  # it makes itself resync every frame
    record = run(link, frames=400)
    most = BUDGETS[BREACH].most
    left = [r.frame for r in record.resyncs if r.node == "left"]
    assert left == list(range(3, 3 + most))  # the budget's resyncs, then given up
    (loss,) = record.losses
    assert (loss.frame, loss.node, loss.detected_by) == (3 + most, "left", BREACH)
    assert record.frames == 400 and record.final.lost == ("left",) and record.final.agree
    assert record.summary()["budgets"][BREACH]["given_up_total"] == 1


def test_the_budgets_and_the_bound_come_from_the_flags_in_either_mode():
    args = cli.build_parser().parse_args(["master", "--walls", "front,left", "--max-lag",
                                          "0.1", "--lag-budget", "3", "--breach-budget", "9"])
    limits = limits_from(args)
    assert limits == {"max_lag": 0.1, "lag_budget": Budget(3, WINDOW),
                      "breach_budget": Budget(9, WINDOW)}
    plain = cli.build_parser().parse_args(["run", "--walls", "2"])
    assert limits_from(plain) == {"max_lag": DEFAULT_MAX_LAG, "lag_budget": BUDGETS[LAG],
                                  "breach_budget": BUDGETS[BREACH]}
    master = RunPlan({"front": ("front",)}, MINIMAL, 10, Path("out"), limits=limits).cluster()
    assert (master.master.max_lag, master.master.lag_budget) == (0.1, Budget(3, WINDOW))


@pytest.mark.parametrize("args, message", [
    (["master", "--walls", "front", "--max-lag", "0"],
     "argument --max-lag: expected seconds in [0.001, 3600.0], got '0'"),
    (["run", "--lag-budget", "0"], "argument --lag-budget: expected lags in [1, 10000]"),
    (["check", "--max-lag", "soon"], "argument --max-lag: expected seconds in"),
    (["check", "--frames", "40", "--inject", "straggler@20:front"],
     "straggler@20:front restarts its node at frame 50, after the last frame 40"),
    (["check", "--frames", "90", "--inject", "straggler@20:front", "--inject", "master-kill@45"],
     "straggler@20:front: a node's own fault (and a straggler's restart, 30 frames on) must "
     "come before the master-kill@45"),
])
def test_bad_limits_are_one_line_usage_errors(args, message, capsys):
    assert cli.main(args) == USAGE_ERROR
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert message in line
