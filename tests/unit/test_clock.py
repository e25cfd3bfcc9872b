"""The master's clock: fixed steps, or real time with an accumulator that never lets a
hitch through as a huge dt."""

import math

import pytest
from master_process import spawn_master

from cavesim.core.clock import DROP_LOG_INTERVAL, Clock, check_dt


class FakeTime:
    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += seconds


def test_fixed_clock_never_waits():
    clock = Clock(1 / 60, realtime=False, now=lambda: 1 / 0, sleep=lambda s: 1 / 0)
    assert [clock.wait_for_frame() for _ in range(3)] == [1 / 60] * 3


def test_realtime_clock_paces_frames_at_the_fixed_step():
    time = FakeTime()
    clock = Clock(0.02, realtime=True, now=time.now, sleep=time.sleep)
    stamps = []
    for _ in range(10):
        assert clock.wait_for_frame() == 0.02
        stamps.append(time.t)
        time.t += 0.005  # the frame's work
    gaps = [b - a for a, b in zip(stamps, stamps[1:], strict=False)]
    assert all(g == pytest.approx(0.02, abs=1e-9) for g in gaps)


def test_a_one_second_hitch_is_clamped_and_caught_up_in_bounded_substeps():
    time = FakeTime()
    clock = Clock(0.02, realtime=True, max_frame_time=0.1, max_substeps=3, now=time.now,
                  sleep=time.sleep)
    clock.wait_for_frame()
    time.t += 1.0  # the hitch
    burst_start = time.t
    dts = [clock.wait_for_frame() for _ in range(3)]
    assert dts == [0.02] * 3 and time.t == burst_start, "three substeps back to back"
    clock.wait_for_frame()
    assert time.t > burst_start, "then it waits again instead of racing on"
    assert clock.dropped_seconds == pytest.approx(0.9 + (0.1 - 3 * 0.02), abs=1e-6)


def test_a_cluster_slower_than_real_time_logs_its_drops_once_a_second(caplog):
    """Behind on every tick (each frame takes 3 dt), the clock writes at most one line per
    DROP_LOG_INTERVAL of its own time; each later line says how many drops it folds in,
    and the total dropped."""
    time = FakeTime()
    clock = Clock(0.01, realtime=True, max_substeps=1, now=time.now, sleep=time.sleep)
    with caplog.at_level("WARNING", logger="cavesim.clock"):
        for _ in range(500):  # 15 s of the clock's time
            clock.wait_for_frame()
            time.t += 0.03  # the frame's work
    lines = [r.getMessage() for r in caplog.records]
    assert 14 <= len(lines) <= 16  # one a second, not one a frame
    assert lines[0].startswith("real-time clock 0.020 s behind: dropped (0.020 s dropped")
    folded = [int(line.split("; ")[1].split()[0]) for line in lines[1:]]
    assert all(n >= DROP_LOG_INTERVAL / 0.03 - 2 for n in folded)
    told = len(lines) + sum(folded)  # every drop up to the last line, each 0.020 s
    assert lines[-1].endswith(f"({told * 0.02:.3f} s dropped in all)")
    assert clock.dropped_seconds == pytest.approx(499 * 0.02, abs=1e-6)  # every tick's


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan, math.inf, 1.0])
def test_bad_dt_is_rejected(dt):
    with pytest.raises(ValueError, match="dt must be finite, > 0 and <= 0.1"):
        check_dt(dt)


@pytest.mark.slow
def test_a_realtime_cluster_keeps_wall_time(tmp_path):
    import json
    import os
    from pathlib import Path

    from nodes.launch.launcher import LocalCluster

    scene = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
    with LocalCluster(scene, tmp_path, f"rt{os.getpid()}") as cluster:
        cluster.start_node("front")
        master = spawn_master(cluster, ("front",), 60, ("--realtime", "--dt", "0.02"))
        master.stdout.read()
        assert master.wait(timeout=60) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["frames"] == 60 and report["seconds"] >= 60 * 0.02 * 0.9
