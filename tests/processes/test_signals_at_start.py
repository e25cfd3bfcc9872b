"""A stopping signal at any moment of a start, as a user or a service manager sends it:
report.json says how the run ended (`interrupted`, which `signal`, `ended_during`
`start-up`) and no node outlives `cavesim run`. The signal comes at a known point each time:
as soon as the process handles SIGTERM (the first line of `cavesim`'s main: it is still
importing), or while the master waits for walls that never come."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from master_process import running

from nodes.arguments import INTERRUPTED
from nodes.launch.launcher import GRACE_SECONDS, free_port

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
PROMPT = 30.0  # s a process has to end after the signal
WAITING = "the master waits for its walls"
# `cavesim run` whose master never gets past waiting for its walls (its nodes are started
# and up): the signal comes before frame 1 whatever the machine's pace
WAITING_RUN = f"""
import sys, time
from nodes.master.process import Master

def wait_for_walls(self):
    print({WAITING!r}, file=sys.stderr, flush=True)
    time.sleep(600)

Master.wait_for_walls = wait_for_walls
from nodes.cli import main
sys.exit(main(sys.argv[1:]))
"""

pytestmark = pytest.mark.slow


def spawn(*args: str, code: str | None = None) -> subprocess.Popen:
    program = ["-c", code] if code else ["-m", "cavesim"]
    return subprocess.Popen([sys.executable, *program, *args], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def handles_sigterm(process: subprocess.Popen) -> None:
    """Wait until `process` has a handler of its own for SIGTERM (the kernel's SigCgt)."""
    deadline = time.monotonic() + PROMPT
    status = Path(f"/proc/{process.pid}/status")
    while time.monotonic() < deadline:
        caught = next(line for line in status.read_text().splitlines()
                      if line.startswith("SigCgt:"))
        if int(caught.split()[1], 16) >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.001)
    raise AssertionError("the process never handled SIGTERM")


def ended_by(process: subprocess.Popen, number: int) -> tuple[float, str]:
    """Send signal `number`; the seconds `process` took to end, and its stderr."""
    sent = time.monotonic()
    process.send_signal(number)
    try:
        _, err = process.communicate(timeout=PROMPT)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    return time.monotonic() - sent, err


def assert_interrupted_at_start(report: Path, name: str) -> None:
    ended = json.loads(report.read_text())
    assert (ended["ended"], ended["ended_during"]) == ("interrupted", "start-up"), ended
    assert ended["interrupted"] and ended["signal"] == name and ended["frames"] == 0


def master_without_walls(report: Path, session: str) -> subprocess.Popen:
    return spawn("master", "--walls", "front,left", "--scene", str(MINIMAL), "--session",
                 session, "--listen", f"tcp/127.0.0.1:{free_port()}", "--join-timeout",
                 "600", "--report", str(report))


def test_sigterm_while_cavesim_master_imports_is_written_into_its_report(tmp_path):
    report = tmp_path / "report.json"
    master = master_without_walls(report, f"startterm{os.getpid()}")
    handles_sigterm(master)
    _, err = ended_by(master, signal.SIGTERM)
    assert master.returncode == INTERRUPTED, err
    assert_interrupted_at_start(report, "SIGTERM")
    assert "Traceback" not in err


def test_sighup_while_the_master_waits_for_its_walls_is_written_into_its_report(tmp_path):
    report = tmp_path / "report.json"
    master = master_without_walls(report, f"starthup{os.getpid()}")
    deadline = time.monotonic() + PROMPT
    while not report.exists():  # the start's checkpoint: it waits for its walls
        assert master.poll() is None and time.monotonic() < deadline, master.stderr.read()
        time.sleep(0.05)
    _, err = ended_by(master, signal.SIGHUP)
    assert master.returncode == INTERRUPTED, err
    assert_interrupted_at_start(report, "SIGHUP")
    assert "interrupted by SIGHUP at frame 0" in err and "Traceback" not in err


def test_sigterm_while_cavesim_run_imports_starts_no_node_and_says_so(tmp_path):
    out, session = tmp_path / "run", f"runterm{os.getpid()}"
    run = spawn("run", "--walls", "2", "--frames", "60", "--scene", str(MINIMAL), "--out",
                str(out), "--session", session)
    handles_sigterm(run)
    _, err = ended_by(run, signal.SIGTERM)
    assert run.returncode == INTERRUPTED, err
    assert_interrupted_at_start(out / "report.json", "SIGTERM")
    assert running(session) == [] and not (out / "logs").exists()  # no node was started


def test_sigint_to_cavesim_run_before_frame_1_ends_every_node_at_once(tmp_path):
    out, session = tmp_path / "run", f"runint{os.getpid()}"
    run = spawn("run", "--walls", "2", "--frames", "60", "--scene", str(MINIMAL), "--out",
                str(out), "--session", session, code=WAITING_RUN)
    deadline = time.monotonic() + PROMPT
    while WAITING not in (line := run.stderr.readline()):
        assert line and time.monotonic() < deadline, "the master did not start"
    started = running(session)
    took, err = ended_by(run, signal.SIGINT)
    assert run.returncode == INTERRUPTED, err
    assert_interrupted_at_start(out / "report.json", "SIGINT")
    assert len(started) == 2 and running(session) == []  # both nodes gone when it ended
    assert took < GRACE_SECONDS / 2  # not the STOP's grace: a node starting never takes it
