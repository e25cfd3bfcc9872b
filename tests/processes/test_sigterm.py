"""SIGTERM (`kill`, a service manager's stop) ends each long-running command as Ctrl-C does:
the master sends STOP and its report says `interrupted`, `cavesim run` stops its nodes, a
node leaves, the tracker writes its --report; no process is left behind."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from master_process import running, spawn_master

from nodes.arguments import INTERRUPTED
from nodes.launch.launcher import LocalCluster, free_port

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
PROMPT = 30.0  # s a process has to end after SIGTERM (its nodes' --master-wait is 60 s)

pytestmark = pytest.mark.slow


def cavesim(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cavesim", *args], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def report_after(path: Path, frames: int, process: subprocess.Popen, seconds: float) -> dict:
    """report.json once it counts `frames` frames (within `seconds`)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        try:
            report = json.loads(path.read_text())
        except (OSError, ValueError):
            report = {}
        if report.get("frames", 0) >= frames:
            return report
        time.sleep(0.2)
    raise AssertionError(f"{path} did not reach frame {frames} within {seconds:g} s")


def terminate(process: subprocess.Popen) -> float:
    """SIGTERM `process`; the seconds it took to end (it is killed past PROMPT)."""
    sent = time.monotonic()
    process.send_signal(signal.SIGTERM)
    try:
        process.wait(timeout=PROMPT)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    return time.monotonic() - sent


def test_sigterm_to_cavesim_run_stops_the_master_and_every_node(tmp_path):
    out, session = tmp_path / "run", f"term{os.getpid()}"
    run = cavesim("run", "--walls", str(len(WALLS)), "--frames", "1000000", "--out", str(out),
                  "--scene", str(MINIMAL), "--session", session)
    report_after(out / "report.json", 20, run, 120)
    took = terminate(run)
    assert run.returncode == INTERRUPTED, run.stderr.read()
    assert took < PROMPT and running(session) == []
    report = json.loads((out / "report.json").read_text())
    assert report["ended"] == "interrupted" and report["interrupted"]
    for wall in WALLS:
        assert "Traceback" not in (out / "logs" / f"{wall}.log").read_text()


def test_sigterm_to_the_master_sends_stop_and_ends_its_report_interrupted(tmp_path):
    session = f"termmaster{os.getpid()}"
    with LocalCluster(MINIMAL, tmp_path, session) as cluster:
        for wall in WALLS:
            cluster.start_node(wall)
        master = spawn_master(cluster, WALLS, 1_000_000)
        report_after(tmp_path / "report.json", 20, master, 120)
        took = terminate(master)
        exits = {wall: node.wait(timeout=PROMPT) for wall, node in cluster.nodes.items()}
    assert master.returncode == INTERRUPTED and took < PROMPT
    assert exits == dict.fromkeys(WALLS, 0)  # they took the STOP, not their --master-wait
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["ended"] == "interrupted"
    assert "Traceback" not in cluster.log_path("master").read_text()


def test_sigterm_to_a_node_ends_it_cleanly(tmp_path):
    session = f"termnode{os.getpid()}"
    node = cavesim("node", "--wall", "front", "--scene", str(MINIMAL), "--session", session,
                   "--listen", f"tcp/127.0.0.1:{free_port()}", "--master-wait", "60",
                   "--verbose")
    deadline = time.monotonic() + 60
    while "up on EGL device" not in (line := node.stderr.readline()):
        assert line and time.monotonic() < deadline, "the node did not come up"
    took = terminate(node)
    err = node.stderr.read()
    # 0 from its loop; 130 when the signal comes just before it (the line is cavesim's)
    assert node.returncode in (0, INTERRUPTED) and took < PROMPT, err
    assert "interrupted" in err and "Traceback" not in err


def test_sigterm_to_the_tracker_writes_its_report(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    report = tmp_path / "tracker.json"
    tracker = cavesim("tracker", "--dtrack", str(port), "--bind", "127.0.0.1", "--map",
                      "config/tracking/dtrack.toml", "--listen",
                      f"tcp/127.0.0.1:{free_port()}", "--session", f"termtrack{os.getpid()}",
                      "--report", str(report), "--verbose")
    deadline = time.monotonic() + 60
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as dtrack:
        dtrack.sendto(b"fr 1\r\n", ("127.0.0.1", port))  # its first, once it listens
        while "first DTrack datagram" not in (line := tracker.stderr.readline()):
            assert line and time.monotonic() < deadline, "the tracker did not come up"
            dtrack.sendto(b"fr 1\r\n", ("127.0.0.1", port))
    took = terminate(tracker)
    err = tracker.stderr.read()
    assert tracker.returncode == 0 and took < PROMPT, err
    assert json.loads(report.read_text())["datagrams"] >= 1
    assert "Traceback" not in err
