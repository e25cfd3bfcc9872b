"""The brownout demo as processes: the rotor's frame parameters keep the walls identical,
the frame log replays bit for bit, and the demo's figures come out."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cavesim.tools.log_replay import replay

ROOT = Path(__file__).parents[2]


@pytest.mark.slow
def test_brownout_run_is_consistent_replays_and_plots(tmp_path, ctx):
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", "420",
               "--out", str(tmp_path), "--session", f"demo{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["divergences"] == [] and report["frames"] == 420
    flight = report["flight"]
    assert flight[-1]["emission_rate"] > flight[0]["emission_rate"] > 0, "more dust lower down"
    assert flight[-1]["altitude"] < flight[0]["altitude"]
    assert report["live_particles"]["max"] > 1000
    cost = report["frame_cost_ms"]  # where each node's frame went
    assert set(cost) == {"front", "left"}
    assert all(cost[wall]["step"]["p50"] > 0 and cost[wall]["checksum"]["p50"] > 0
               and cost[wall]["input_wait"]["p99"] > 0 for wall in cost)
    assert "where each node's frame went" in result.stdout
    assert [Path(p).name for p in report["plots"]] == ["live_and_emission_vs_time.png",
                                                       "emission_vs_altitude.png"]
    result = replay(tmp_path / "frames.log", ROOT / "config/scenes/brownout.toml", ctx=ctx)
    assert result.frames == 420 and result.equal, result.mismatches[:2]
