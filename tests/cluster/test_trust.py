"""Trust and failure with real processes: a master killed with SIGKILL whose nodes a new
master takes over, and a master and nodes started with keys that do not match, each side
saying so in one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from master_process import progress_until, spawn_master

from cavesim.core.wire.credentials import generate
from cavesim.core.wire.key_files import write_key_files
from nodes.arguments import lost_walls_code
from nodes.launch.launcher import LocalCluster
from nodes.lockstep import MASTER_GONE

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")

pytestmark = pytest.mark.slow


def test_a_sigkilled_master_is_noticed_and_a_new_master_takes_the_nodes_over(tmp_path):
    master_key, *_ = write_key_files(tmp_path / "keys", generate(), WALLS)
    session = f"kill{os.getpid()}"
    with LocalCluster(MINIMAL, tmp_path, session, keys=tmp_path / "keys") as cluster:
        for wall in WALLS:
            cluster.start_node(wall)
        first = spawn_master(cluster, WALLS, 100_000, key_file=master_key)
        progress_until(first, 50)
        os.killpg(first.pid, signal.SIGKILL)  # no STOP, no clean close: as a crash
        first.wait(timeout=10)
        killed = json.loads((tmp_path / "report.json").read_text())
        assert killed["ended"] == "running" and killed["frames"] >= 1  # its last checkpoint

        second = spawn_master(cluster, WALLS, 120, key_file=master_key)
        assert second.wait(timeout=120) == 0, (tmp_path / "logs" / "master.log").read_text()
        exits = {wall: node.wait(timeout=30) for wall, node in cluster.nodes.items()}
    assert exits == dict.fromkeys(WALLS, 0)  # the nodes stayed up, then took the new STOP
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["ended"] == "finished" and report["frames"] == 120
    assert report["run_id"] != killed["run_id"]
    assert report["final"]["agree"] and report["final"]["members"] == list(WALLS)
    for wall in WALLS:
        log = cluster.log_path(wall).read_text()
        assert MASTER_GONE in log and f"a new master's run {report['run_id']}" in log
        assert "Traceback" not in log


def test_mismatched_keys_are_named_on_both_sides(tmp_path):
    master_key, _ = write_key_files(tmp_path / "master-keys", generate(), ("front",))
    write_key_files(tmp_path / "other-keys", generate(), ("front",))
    session = f"keys{os.getpid()}"
    with LocalCluster(MINIMAL, tmp_path, session, keys=tmp_path / "other-keys") as cluster:
        cluster.start_node("front", extra=("--master-wait", "8"))
        master = spawn_master(cluster, ("front",), 10, ("--join-timeout", "8"),
                              key_file=master_key)
        assert master.wait(timeout=60) == 1
        node_exit = cluster.nodes["front"].wait(timeout=60)
    master_line = (tmp_path / "logs" / "master.log").read_text().strip().splitlines()[-1]
    assert "did not join within 8 s (--join-timeout)" in master_line
    assert "fails its signature" in master_line and "check --key-file" in master_line
    assert node_exit == 1
    node_line = cluster.log_path("front").read_text().strip().splitlines()[-1]
    assert "no master welcomed it within 8 s (--master-wait)" in node_line
    assert "fails its signature" in node_line and "check --key-file" in node_line


def test_keys_are_never_overwritten_and_the_master_needs_master_key(tmp_path):
    master_key, _ = write_key_files(tmp_path, generate(), ("front",))
    again = subprocess.run([sys.executable, "-m", "cavesim", "keys", "--out", str(tmp_path),
                            "--walls", "front"],
                           capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert again.returncode == 2 and "already holds master.key, wall-front.key" in again.stderr
    assert oct(master_key.stat().st_mode & 0o777) == "0o600"
    master = subprocess.run([sys.executable, "-m", "cavesim", "master", "--walls", "front",
                           "--key-file", str(tmp_path / "wall-front.key")],
                          capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert master.returncode == 2
    assert "holds the key of wall front; this needs master's" in master.stderr


def test_a_wall_lost_for_good_makes_the_master_exit_1_unless_continue_was_asked(tmp_path):
    session = f"lost{os.getpid()}"
    with LocalCluster(MINIMAL, tmp_path, session) as cluster:
        for wall in WALLS:
            cluster.start_node(wall)
        master = spawn_master(cluster, WALLS, 150)
        progress_until(master, 20)
        cluster.kill_node("left")  # and never started again
        assert master.wait(timeout=120) == 1
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["frames"] == 150 and report["final"]["lost"] == ["left"]
    line = (tmp_path / "logs" / "master.log").read_text().strip().splitlines()[-1]
    assert line == ("cavesim master: error: wall(s) left lost for good: the run ended without "
                    "them (see the report's losses); give --on-loss continue to accept that")


@pytest.mark.parametrize(("lost", "on_loss", "code"), [
    ((), None, 0), (("left",), None, 1), (("left",), "pause", 1), (("left",), "continue", 0)])
def test_the_exit_code_of_a_run_that_lost_walls(lost, on_loss, code):
    assert lost_walls_code(lost, on_loss, "run") == code
