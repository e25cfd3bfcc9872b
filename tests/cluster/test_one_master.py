"""One master per session, with real processes: a second master started with the same
session and key beside a running one (which started first) is refused on both sides, and
no node leaves the first run for it (the master-kill takeover, where the first master is
gone, is in test_trust.py)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from master_process import progress_until, spawn_master

from cavesim.core.wire.credentials import generate
from cavesim.core.wire.envelope import run_started
from cavesim.core.wire.key_files import write_key_files
from nodes.launch.launcher import LocalCluster

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
FRAMES = 900  # at 60 frames per second (--realtime): the second master comes and goes in it

pytestmark = pytest.mark.slow


def test_a_second_master_of_the_session_is_refused_and_no_node_leaves_the_first(tmp_path):
    master_key, *_ = write_key_files(tmp_path / "keys", generate(), WALLS)
    session = f"one{os.getpid()}"
    second_out = tmp_path / "second"
    with LocalCluster(MINIMAL, tmp_path, session, keys=tmp_path / "keys") as cluster:
        for wall in WALLS:
            cluster.start_node(wall)
        first = spawn_master(cluster, WALLS, FRAMES, ("--realtime",), key_file=master_key)
        progress_until(first, 30)
        first_run = json.loads((tmp_path / "report.json").read_text())["run_id"]

        second = spawn_master(cluster, WALLS, 60, ("--join-timeout", "60"),
                              key_file=master_key, out=second_out,
                              network=("--connect", cluster.master_endpoint,
                                       "--listen", "tcp/127.0.0.1:0"))
        assert second.wait(timeout=60) == 1
        still_running = first.poll() is None
        progress_until(first, FRAMES)
        assert first.wait(timeout=60) == 0, (tmp_path / "logs" / "master.log").read_text()
        exits = {wall: node.wait(timeout=30) for wall, node in cluster.nodes.items()}
    assert still_running  # the second master was refused while the first one ran
    second_run = json.loads((second_out / "report.json").read_text())["run_id"]
    second_line = (second_out / "logs" / "master.log").read_text().strip().splitlines()[-1]
    assert second_line == (f"cavesim: error: another master's run {first_run}, started "
                           f"first (at {run_started(int(first_run, 16))}), is on session "
                           f"{session}: refusing to start run {second_run}; stop that "
                           f"master first")

    assert exits == dict.fromkeys(WALLS, 0)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["run_id"] == first_run and report["frames"] == FRAMES
    assert report["final"]["agree"] and report["final"]["members"] == list(WALLS)
    assert report["joins"] == [] and report["losses"] == [] and report["resyncs"] == []
    assert report["rejected_messages"]["master"].get("other-master", 0) >= 1
    first_log = (tmp_path / "logs" / "master.log").read_text()
    assert f"another master's run {second_run}" in first_log
    for wall in WALLS:
        log = cluster.log_path(wall).read_text()
        assert log.count("joined run") == 1 and f"joined run {first_run}" in log
        assert "a new master's run" not in log and "Traceback" not in log
