"""Crash-safe records: report.json checkpointed while the master runs and left whole by a
SIGKILL; the frame log's whole records kept through a crash; an output path of the wrong
kind refused in one line before anything starts; a deleted output folder or a full disk
is one line naming the file, and the frames logged before it stay replayable."""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from memory_walls import MemoryLink
from rich.console import Console

from cavesim.core.errors import ClusterError, OutputError
from cavesim.core.framelog import TORN, read_frame_log
from cavesim.core.output import writing
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.key_files import write_key_files
from cavesim.tools.log_replay import replay
from nodes import cli
from nodes.arguments import USAGE_ERROR, UsageError, output_directory
from nodes.master import report_file
from nodes.master.process import MasterConfig, run_master
from nodes.master.report_file import FAILED, FINISHED, INTERRUPTED, RUNNING, STOPPED, ReportFile
from nodes.master.run_record import RunRecord

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")

# The master over memory walls in a process of its own, checkpointing report.json, until
# it is killed; argv: OUT.
MASTER_UNTIL_KILLED = f"""
import sys
from pathlib import Path
sys.path.insert(0, {str(Path(__file__).parents[1] / "support")!r})
from memory_walls import MemoryLink
from nodes.master.process import MasterConfig, run_master
from nodes.master.report_file import ReportFile

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


def kill_nodes_of(session: str) -> None:
    found = subprocess.run(["pgrep", "-f", f"cavesim node .*--session {session} "],
                           capture_output=True, text=True).stdout.split()
    for pid in map(int, found):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


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
    report.finish(record(4).summary(), interrupted=False, stopped=True)
    assert read_report(path)["ended"] == STOPPED  # the user's Esc in the preview
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
    assert seen == list(range(0, 21))  # the start, then every frame
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
    session = f"k{os.getpid()}"
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", "100000",
               "--scene", str(MINIMAL), "--out", str(tmp_path), "--session", session]
    run = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, start_new_session=True)
    try:
        path = tmp_path / "report.json"
        wait_for(lambda: frames_checkpointed(path) > 1, "second checkpoint", run)
        os.kill(run.pid, signal.SIGKILL)
        run.wait(timeout=30)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
        kill_nodes_of(session)  # in sessions of their own, they outlive a SIGKILLed master
    written = read_report(tmp_path / "report.json")
    assert written["ended"] == RUNNING and written["frames"] > 1
    assert written["divergences"] == []
    result = replay(tmp_path / "frames.log", MINIMAL, ctx=ctx)
    assert result.equal and result.frames >= written["frames"], result.mismatches[:3]
    assert result.damage is None or result.damage.kind == TORN


# -- an output path of the wrong kind ----------------------------------------------------------

FOLDER_FLAGS = [  # (argv before the flag, the flag): each takes a folder
    pytest.param(["run", "--walls", "1"], "--out", id="run"),
    pytest.param(["check"], "--out", id="check"),
    pytest.param(["bench"], "--out", id="bench"),
    pytest.param(["bench", "--cluster"], "--out", id="bench-cluster"),
    pytest.param(["accuracy"], "--out", id="accuracy"),
    pytest.param(["stability"], "--out", id="stability"),
    pytest.param(["replay", str(MINIMAL)], "--out", id="replay"),
    pytest.param(["render", str(MINIMAL)], "--out", id="render"),
    pytest.param(["node", "--wall", "front"], "--images", id="node-images"),
]
FILE_FLAGS = [  # each takes a file
    pytest.param(["doctor"], "--out", id="doctor"),
    pytest.param(["master", "--walls", "front", "--frames", "1"], "--report",
                 id="master-report"),
    pytest.param(["master", "--walls", "front", "--frames", "1"], "--frame-log",
                 id="master-frame-log"),
    pytest.param(["tracker", "--dtrack", "5000"], "--report", id="tracker-report"),
]


def one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    (line,) = captured.err.splitlines()
    return line


@pytest.mark.parametrize(("argv", "flag"), FOLDER_FLAGS)
def test_a_folder_flag_given_a_file_is_one_line_before_anything_starts(capsys, tmp_path, argv,
                                                                       flag):
    taken = tmp_path / "taken"
    taken.write_text("mine")
    assert cli.main([*argv, flag, str(taken)]) == USAGE_ERROR
    assert one_error_line(capsys) == (f"cavesim {argv[0]}: error: argument {flag}: "
                                      f"{str(taken)!r} is a file; give a folder (a new one "
                                      f"is made)")
    assert taken.read_text() == "mine" and list(tmp_path.iterdir()) == [taken]


@pytest.mark.parametrize(("argv", "flag"), FILE_FLAGS)
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


# -- a deleted folder, a full disk, files said to be written -----------------------------------

@pytest.fixture
def small_disk(tmp_path):
    """A folder on a tmpfs of its own: 256 KiB fill up within seconds of a run."""
    yield from mounted_tmpfs(tmp_path / "disk", "256k")


@pytest.fixture
def disk_for_pictures(tmp_path):
    """A tmpfs of 2 MiB: room for the frame log and a few frames of every wall's pictures."""
    yield from mounted_tmpfs(tmp_path / "disk", "2m")


def mounted_tmpfs(folder: Path, size: str):
    folder.mkdir()
    try:
        mount = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                                str(folder)], capture_output=True, text=True)
        refused = mount.stderr.strip() if mount.returncode else None
    except OSError as e:  # no mount command at all
        refused = str(e)
    if refused is not None:
        pytest.skip(f"a full disk needs a tmpfs of its own, and mount is not permitted here "
                    f"(it needs root with CAP_SYS_ADMIN): {refused}")
    try:
        yield folder
    finally:
        if subprocess.run(["umount", str(folder)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(folder)], check=True)  # busy: detach it


def test_a_full_disk_ends_the_report_failed_at_the_frames_logged(small_disk):
    """The report's last checkpoint cannot be replaced on a full disk: the space it keeps
    in reserve takes the failed report, which counts the frames the log holds."""
    config = MasterConfig(WALLS, MINIMAL, 10**6, frame_log=small_disk / "frames.log")
    with pytest.raises(OutputError), ReportFile(small_disk / "report.json") as report:
        run_master(config, MemoryLink(WALLS), checkpoint=report.checkpoint)
    _, frames = read_frame_log(small_disk / "frames.log")
    written = read_report(small_disk / "report.json")
    assert written["ended"] == FAILED and written["frames"] == len(frames) > 100
    assert written["error"].endswith(": No space left on device"), written["error"]
    assert sorted(p.name for p in small_disk.iterdir()) == ["frames.log", "report.json"]


def test_a_master_whose_walls_never_join_writes_a_failed_report(tmp_path):
    config = MasterConfig(WALLS, MINIMAL, 10, join_timeout=0.5)
    with pytest.raises(ClusterError), ReportFile(tmp_path / "report.json") as report:
        run_master(config, MemoryLink(WALLS, late=WALLS), checkpoint=report.checkpoint)
    written = read_report(tmp_path / "report.json")
    assert written["ended"] == FAILED and written["frames"] == 0
    assert written["error"].startswith("walls ['front', 'left'] did not join within 0.5 s")


def cavesim_run(out: Path, *extra: str) -> subprocess.Popen:
    command = [sys.executable, "-m", "cavesim", "run", "--frames", "100000", "--scene",
               str(MINIMAL), "--out", str(out), "--session", f"d{os.getpid()}", *extra]
    return subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def finished(run: subprocess.Popen, timeout: float = 120) -> tuple[int, str, str]:
    try:
        out, err = run.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(run.pid, signal.SIGKILL)
        run.communicate()
        raise
    return run.returncode, out, err


def test_a_full_disk_ends_the_master_with_an_output_error_and_keeps_the_whole_frames(
        small_disk):
    config = MasterConfig(WALLS, MINIMAL, 10**6, frame_log=small_disk / "frames.log")
    with pytest.raises(OutputError) as caught, ReportFile(small_disk / "report.json") as report:
        run_master(config, MemoryLink(WALLS), checkpoint=report.checkpoint)
    message = str(caught.value)
    assert message.startswith(f"cannot write {small_disk}/") and \
        message.endswith(": No space left on device"), message
    _, frames = read_frame_log(small_disk / "frames.log")
    assert len(frames) > 100 and (frames.damage is None or frames.damage.kind == TORN)
    written = read_report(small_disk / "report.json")  # a checkpoint, or the failure
    assert written["ended"] == FAILED and 0 < written["frames"] <= len(frames)


@pytest.mark.slow
def test_a_full_disk_is_one_line_naming_the_file_and_the_logged_frames_replay(small_disk,
                                                                              ctx):
    out = small_disk / "run"
    code, stdout, stderr = finished(cavesim_run(out, "--walls", "1"))
    assert code == 1 and "Traceback" not in stderr and "wrote" not in stdout
    (line,) = stderr.splitlines()
    assert line.startswith(f"cavesim: error: cannot write {out}/") and \
        line.endswith(": No space left on device"), line
    result = replay(out / "frames.log", MINIMAL, ctx=ctx)
    assert result.equal and result.frames > 100, result.mismatches[:3]
    assert result.damage is None or result.damage.kind == TORN
    assert read_report(out / "report.json")["frames"] <= result.frames


@pytest.mark.slow
def test_a_full_disk_under_the_pictures_is_one_line_naming_the_file(disk_for_pictures):
    out = disk_for_pictures / "run"
    code, stdout, stderr = finished(cavesim_run(out, "--render-every", "1"))
    assert code == 1 and "Traceback" not in stderr and "wrote" not in stdout
    (line,) = stderr.splitlines()
    assert line.startswith("cavesim: error: "), line
    assert f"cannot write {out}/" in line and ": No space left on device" in line, line
    written = read_report(out / "report.json")
    assert written["ended"] in (RUNNING, FAILED) and written["frames"] > 0


@pytest.mark.slow
def test_an_output_folder_deleted_mid_run_is_one_line_naming_it(tmp_path):
    out = tmp_path / "run"
    run = cavesim_run(out, "--walls", "1")
    wait_for(lambda: frames_checkpointed(out / "report.json") > 1, "second checkpoint", run)
    shutil.rmtree(out)
    code, stdout, stderr = finished(run)
    assert code == 1 and "Traceback" not in stderr and "wrote" not in stdout
    (line,) = stderr.splitlines()
    assert line.startswith(f"cavesim: error: cannot write {out}/"), line
    assert line.endswith(f": its folder {out} is gone"), line


def test_wrote_is_said_only_of_files_that_are_there(tmp_path, monkeypatch):
    from cavesim.tools.reports import demo
    from nodes.commands import run as run_command

    gone = tmp_path / "plots" / "live.png"
    monkeypatch.setattr(demo, "write_demo_plots", lambda report, out: [gone])
    console = Console(file=io.StringIO())
    with pytest.raises(OutputError, match=f"^{gone} is missing: its folder "
                                          f"{gone.parent} is gone$"):
        run_command.write_plots({"flight": [{}]}, tmp_path, console)
    assert "wrote" not in console.file.getvalue()


def test_an_output_error_names_the_file_the_system_named(tmp_path):
    with pytest.raises(OutputError, match=f"^cannot write {tmp_path / 'no' / 'x.png'}: its "
                                          f"folder {tmp_path / 'no'} is gone$"), \
            writing(tmp_path):
        open(tmp_path / "no" / "x.png", "wb")


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_a_picture_on_a_full_disk_is_an_output_error_naming_it(tmp_path):
    """The animation and the demo's plots, written through a link to /dev/full."""
    from PIL import Image

    from cavesim.gpu.render.animation import write_animation
    from cavesim.tools.reports.demo import write_demo_plots

    frame = tmp_path / "frame.png"
    Image.new("RGB", (8, 8)).save(frame)
    animation = tmp_path / "run.gif"
    animation.symlink_to("/dev/full")
    with pytest.raises(OutputError, match=f"^cannot write {animation}: No space left on device$"):
        write_animation([frame], animation)
    plot = tmp_path / "plots" / "live_and_emission_vs_time.png"
    plot.parent.mkdir()
    plot.symlink_to("/dev/full")
    flight = [{"t": t / 60, "altitude": 10.0 - t, "emission_rate": 100.0 * t} for t in range(5)]
    with pytest.raises(OutputError, match=f"^cannot write {plot}: No space left on device$"):
        write_demo_plots({"flight": flight, "live_per_frame": [1, 2, 3, 4, 5]}, tmp_path)


def test_a_run_with_a_key_file_leaves_no_secret_in_its_output_folder(tmp_path):
    """`cavesim run --key-file master.key` issues its walls' keys into a private temporary
    folder: nothing under --out, logs included, holds a key file or a secret."""
    keys, out = tmp_path / "keys", tmp_path / "out"
    master = generate()
    write_key_files(keys, master, ("front", "left"))
    done = subprocess.run([sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames",
                           "20", "--scene", str(MINIMAL), "--out", str(out), "--session",
                           f"s{os.getpid()}", "--key-file", str(keys / "master.key")],
                          cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr[-2000:]
    files = [path for path in out.rglob("*") if path.is_file()]
    assert files and not [path for path in files if path.suffix == ".key"]
    secrets = [master.secret, master.master_private]
    secrets += [encoded for secret in secrets for encoded in (secret.hex().encode(),
                                                              base64.b64encode(secret))]
    assert [path.name for path in files
            if any(secret in path.read_bytes() for secret in secrets)] == []
