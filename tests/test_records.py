"""Crash-safe records: report.json checkpointed while the master runs and left whole by a
SIGKILL; the frame log's whole records kept through a crash; an output path of the wrong
kind refused in one line before anything starts."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from memory_walls import MemoryLink

from cavesim.core.errors import ClusterError
from cavesim.core.framelog import TORN, read_frame_log
from cavesim.nodes import report_file
from cavesim.nodes.master import MasterConfig, run_master
from cavesim.nodes.record import RunRecord
from cavesim.nodes.report_file import FAILED, FINISHED, INTERRUPTED, RUNNING, ReportFile
from cavesim.tools import cli
from cavesim.tools.arguments import USAGE_ERROR, UsageError, output_directory
from cavesim.tools.replay import replay

ROOT = Path(__file__).parents[1]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")

# The master over memory walls in a process of its own, checkpointing report.json, until
# it is killed; argv: OUT.
MASTER_UNTIL_KILLED = f"""
import sys
from pathlib import Path
sys.path.insert(0, {str(Path(__file__).parent)!r})
from memory_walls import MemoryLink
from cavesim.nodes.master import MasterConfig, run_master
from cavesim.nodes.report_file import ReportFile

out = Path(sys.argv[1])
config = MasterConfig({WALLS!r}, Path({str(MINIMAL)!r}), 10**9, frame_log=out / "frames.log")
with ReportFile(out / "report.json") as report:
    run_master(config, MemoryLink(config.walls), checkpoint=report.checkpoint)
"""


def read_report(path: Path) -> dict:
    return json.loads(path.read_text())


def wait_for(predicate, what: str, process: subprocess.Popen | None = None,
             timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"no {what} after {timeout:g} s"
        assert process is None or process.poll() is None, \
            f"exited with {process.returncode} before {what}"
        time.sleep(0.05)


def frames_checkpointed(path: Path) -> int:
    try:
        return read_report(path)["frames"]
    except (OSError, ValueError):  # not there yet
        return 0


def record(frames: int) -> RunRecord:
    result = RunRecord(WALLS)
    result.frames = frames
    return result


# -- checkpoints -------------------------------------------------------------------------------

def test_the_first_frame_is_checkpointed_then_at_most_once_a_second(tmp_path, monkeypatch):
    now = [100.0]
    monkeypatch.setattr(report_file.time, "monotonic", lambda: now[0])
    written = []
    monkeypatch.setattr(report_file, "write_atomically",
                        lambda path, text: written.append(json.loads(text)["frames"]))
    report = ReportFile(tmp_path / "report.json")
    for k in range(1, 251):  # 100 frames a second for 2.5 s
        report.checkpoint(record(k))
        now[0] += 0.01
    assert written == [1, 101, 201]


def test_a_slow_checkpoint_is_spaced_out_to_keep_its_share_of_the_run_small(tmp_path,
                                                                              monkeypatch):
    now = [0.0]
    monkeypatch.setattr(report_file.time, "monotonic", lambda: now[0])

    def slow_write(path, text):
        now[0] += 0.2  # a huge summary: 0.2 s a write
        written.append(json.loads(text)["frames"])

    written = []
    monkeypatch.setattr(report_file, "write_atomically", slow_write)
    report = ReportFile(tmp_path / "report.json")
    for k in range(1, 1001):
        report.checkpoint(record(k))
        now[0] += 0.01
    # the next after BUDGET_RATIO * 0.2 s = 4 s (3.8 s of frames after the write), not 1 s
    assert written[0] == 1 and 375 <= written[1] - written[0] <= 385, written


def test_checkpoints_say_running_and_the_end_says_how_the_run_ended(tmp_path):
    path = tmp_path / "report.json"
    report = ReportFile(path)
    report.checkpoint(record(1))
    assert read_report(path)["ended"] == RUNNING and read_report(path)["frames"] == 1
    report.finish(record(7).summary(), interrupted=False)
    assert read_report(path)["ended"] == FINISHED and read_report(path)["frames"] == 7
    report.finish(record(3).summary(), interrupted=True)
    assert read_report(path)["ended"] == INTERRUPTED
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"], "no temporary left"


def test_an_error_that_ends_the_run_is_written_as_failed_with_its_line(tmp_path):
    path = tmp_path / "report.json"
    with pytest.raises(ClusterError), ReportFile(path) as report:
        report.checkpoint(record(4))
        raise ClusterError("wall left exited with code 1: boom")
    written = read_report(path)
    assert written["ended"] == FAILED and written["frames"] == 4
    assert written["error"] == "wall left exited with code 1: boom"


def test_the_master_checkpoints_through_its_hook(tmp_path):
    path = tmp_path / "report.json"
    config = MasterConfig(WALLS, MINIMAL, 20)
    seen = []
    with ReportFile(path) as report:
        def checkpoint(run: RunRecord) -> None:
            seen.append(run.frames)
            report.checkpoint(run)

        final = run_master(config, MemoryLink(WALLS), checkpoint=checkpoint)
        assert read_report(path)["ended"] == RUNNING and read_report(path)["frames"] >= 1
        report.finish(final.summary(), final.interrupted)
    assert seen == list(range(1, 21))
    assert read_report(path)["ended"] == FINISHED and read_report(path)["frames"] == 20


# -- SIGKILL -----------------------------------------------------------------------------------

def test_a_sigkilled_master_leaves_a_whole_report_and_its_whole_frames(tmp_path):
    master = subprocess.Popen([sys.executable, "-c", MASTER_UNTIL_KILLED, str(tmp_path)],
                              cwd=ROOT, stderr=subprocess.PIPE, start_new_session=True)
    try:
        path = tmp_path / "report.json"
        wait_for(lambda: frames_checkpointed(path) > 1, "second checkpoint", master)
        os.kill(master.pid, signal.SIGKILL)
        assert master.wait(timeout=30) == -signal.SIGKILL
    finally:
        if master.poll() is None:
            os.killpg(master.pid, signal.SIGKILL)
            master.wait()
    written = read_report(tmp_path / "report.json")
    assert written["ended"] == RUNNING and written["frames"] > 1
    _, frames = read_frame_log(tmp_path / "frames.log")
    assert frames.damage is None or frames.damage.kind == TORN
    assert len(frames) >= written["frames"], "a checkpoint follows its frame's record"


@pytest.mark.slow
def test_a_sigkilled_run_leaves_its_report_and_a_log_that_replays(tmp_path, ctx):
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", "100000",
               "--scene", str(MINIMAL), "--out", str(tmp_path), "--session", f"k{os.getpid()}"]
    run = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, start_new_session=True)
    try:
        path = tmp_path / "report.json"
        wait_for(lambda: frames_checkpointed(path) > 1, "second checkpoint", run)
        os.killpg(run.pid, signal.SIGKILL)  # the run and its nodes, as a crash of the host
        run.wait(timeout=30)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    written = read_report(tmp_path / "report.json")
    assert written["ended"] == RUNNING and written["frames"] > 1
    assert written["divergences"] == []
    result = replay(tmp_path / "frames.log", MINIMAL, ctx=ctx)
    assert result.equal and result.frames >= written["frames"], result.mismatches[:3]
    assert result.damage is None or result.damage.kind == TORN


# -- an output path of the wrong kind ----------------------------------------------------------

FOLDER_FLAGS = [  # (argv before the flag, the flag): each takes a folder
    (["run", "--walls", "1"], "--out"),
    (["check"], "--out"),
    (["bench"], "--out"),
    (["bench", "--cluster"], "--out"),
    (["accuracy"], "--out"),
    (["stability"], "--out"),
    (["replay", str(MINIMAL)], "--out"),
    (["node", "--wall", "front"], "--images"),
]
FILE_FLAGS = [  # each takes a file
    (["doctor"], "--out"),
    (["master", "--walls", "front", "--frames", "1"], "--report"),
    (["master", "--walls", "front", "--frames", "1"], "--frame-log"),
    (["tracker", "--dtrack", "5000"], "--report"),
]


def one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    (line,) = captured.err.splitlines()
    return line


@pytest.mark.parametrize(("argv", "flag"), FOLDER_FLAGS, ids=lambda v: " ".join(v)
                         if isinstance(v, list) else v)
def test_a_folder_flag_given_a_file_is_one_line_before_anything_starts(capsys, tmp_path, argv,
                                                                       flag):
    taken = tmp_path / "taken"
    taken.write_text("mine")
    assert cli.main([*argv, flag, str(taken)]) == USAGE_ERROR
    assert one_error_line(capsys) == (f"cavesim {argv[0]}: error: argument {flag}: "
                                      f"{str(taken)!r} is a file; give a folder (a new one "
                                      f"is made)")
    assert taken.read_text() == "mine" and list(tmp_path.iterdir()) == [taken]


@pytest.mark.parametrize(("argv", "flag"), FILE_FLAGS, ids=lambda v: " ".join(v)
                         if isinstance(v, list) else v)
def test_a_file_flag_given_a_folder_or_a_path_under_a_file_is_one_line(capsys, tmp_path, argv,
                                                                       flag):
    assert cli.main([*argv, flag, str(tmp_path)]) == USAGE_ERROR
    assert one_error_line(capsys) == (f"cavesim {argv[0]}: error: argument {flag}: "
                                      f"{str(tmp_path)!r} is a folder; give the path of a file")
    (tmp_path / "taken").write_text("mine")
    under = tmp_path / "taken" / "x.json"
    assert cli.main([*argv, flag, str(under)]) == USAGE_ERROR
    assert one_error_line(capsys) == (f"cavesim {argv[0]}: error: argument {flag}: "
                                      f"{str(under)!r}: {str(tmp_path / 'taken')!r} is a "
                                      f"file, not a folder; give a path in a folder")


def test_a_default_output_folder_that_is_a_file_is_refused_as_well(tmp_path):
    taken = tmp_path / "out"  # a default (a Path) skips argparse's type: the command checks
    taken.write_text("")
    with pytest.raises(UsageError, match=r"^cavesim run: error: argument --out: .* is a file; "
                                         r"give a folder \(a new one is made\)$"):
        output_directory(taken, "run")
