"""The run record of a long run: its memory does not grow with the frames, its summary
(report.json) stays right."""

import math
import tracemalloc

import numpy as np
import pytest

from cavesim.core.bounded.histogram import RELATIVE_ERROR
from cavesim.core.drivers import FlightSample
from nodes.master.run_record import Divergence, RunRecord, Stall

FRAMES = 1_000_000


def live_after(k: int) -> int:
    """A live count that says its frame, peaking at 1,234,567 on frame 777,777."""
    return 1_234_567 if k == 777_777 else k % 100_000 + 1000


@pytest.mark.slow
def test_a_million_frames_keep_the_record_small_and_its_summary_right():
    barrier = np.random.default_rng(13).lognormal(math.log(2e-3), 0.5, FRAMES)
    barrier_seconds = barrier.tolist()  # made before the measuring starts
    record = RunRecord(("front", "left"))
    tracemalloc.start()
    try:
        started = tracemalloc.get_traced_memory()[0]
        peaks = []  # the highest traced memory in frames 1..100,000, then in the rest
        for k in range(1, FRAMES + 1):
            record.add_flight(FlightSample(k / 60, 10.0, 1.0, 9.0, 5000.0))
            record.frame_done(k, barrier_seconds[k - 1], live_after(k))
            if k in (FRAMES // 10, FRAMES):
                peaks.append(tracemalloc.get_traced_memory()[1] - started)
                tracemalloc.reset_peak()
    finally:
        tracemalloc.stop()
    first, rest = peaks  # the series are full from frame 4,096 on: the rest adds nothing
    assert rest <= first + 16 * 1024, f"{first:,} B in the first 100,000 frames, then {rest:,}"
    assert first < 2 * 1024 * 1024, f"{first:,} B"

    report = record.summary()
    assert report["frames"] == FRAMES
    for name, q in (("p50", 50), ("p99", 99)):
        exact = np.percentile(barrier, q) * 1e3
        assert report["barrier_ms"][name] == pytest.approx(exact, rel=RELATIVE_ERROR, abs=5e-4)
    assert report["barrier_ms"]["max"] == round(barrier.max() * 1e3, 3)
    assert report["live_particles"] == {"last": live_after(FRAMES), "max": 1_234_567}
    stride = report["live_frames_stride"]
    assert stride == 256 and len(report["live_per_frame"]) == FRAMES // stride
    assert report["live_per_frame"] == [live_after(k) for k in range(stride, FRAMES + 1, stride)]
    assert report["flight_frames_stride"] == stride
    assert [f["t"] for f in report["flight"]] == [round(k / 60, 4) for k in
                                                 range(stride, FRAMES + 1, stride)]


def test_event_lists_keep_their_first_entries_and_count_every_one():
    record = RunRecord(("front", "left"))
    for k in range(1, 5001):
        record.divergences.append(Divergence(k, ("left",), "a" * 32, {}, {}))
    record.stalls.append(Stall(3, {"left": (3, 2)}))
    report = record.summary()
    assert [d["frame"] for d in report["divergences"]] == list(range(1, 1001))
    assert report["event_totals"] == {"divergences": 5000, "resyncs": 0, "stalls": 1,
                                      "lags": 0, "losses": 0, "joins": 0, "user_actions": 0}
    assert report["stalls"] == [{"frame": 3, "nodes": {
        "left": {"last_frame_sent": 3, "last_frame_received": 2}}}]


def test_frames_are_done_in_order():
    record = RunRecord(("front",))
    record.frame_done(1, 1e-3, 10)
    with pytest.raises(ValueError, match="expected frame 2, got k=3"):
        record.frame_done(3, 1e-3, 10)


def test_an_empty_record_summarizes():
    report = RunRecord(("front",)).summary()
    assert report["barrier_ms"] == {"p50": None, "p99": None, "max": None}
    assert report["live_particles"] == {"last": 0, "max": 0} and report["live_per_frame"] == []
    assert report["swap"]["skew_ms"]["p50"] is None and report["swap"]["stalls_total"] == 0


def test_render_cost_per_wall_counts_the_drawn_frames_alone():
    """A node drawing every 4th frame: its render p50 over all frames is 0, over the frames
    it drew the drawing's; a node of two walls shares its drawing between them."""
    from cavesim.core.frame_cost import PHASES

    record = RunRecord(("solo", "pair"), node_walls={"solo": ("front",),
                                                     "pair": ("left", "right")})
    render = PHASES.index("render")
    for k in range(1, 41):
        drawn_us = 8000 if k % 4 == 0 else 0
        cost = tuple(drawn_us if i == render else 100 for i in range(len(PHASES)))
        record.frame_cost.add("solo", cost)
        record.frame_cost.add("pair", cost)
    summary = record.summary()
    assert summary["frame_cost_ms"]["solo"]["render"]["p50"] <= 0.001
    solo, pair = summary["render_ms_per_wall"]["solo"], summary["render_ms_per_wall"]["pair"]
    assert (solo["walls"], solo["drawn_frames"]) == (["front"], 10)
    assert solo["p50"] == pytest.approx(8.0, rel=1e-3)
    assert (pair["walls"], pair["drawn_frames"]) == (["left", "right"], 10)
    assert pair["p50"] == pytest.approx(4.0, rel=1e-3)
