"""`cavesim run` fails fast and clearly: files checked before anything starts, a process that
exits early stops the others at once and is named with its own error line and its log,
and no traceback reaches the user."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cavesim.core.errors import ClusterError
from nodes import cli
from nodes.arguments import RUN_ERROR
from nodes.commands import numerics
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.launch.launcher import last_error
from nodes.master.process import MasterConfig

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
JOIN_TIMEOUT = 60.0  # the master's default: failing fast means long before it


def cavesim(*args: str, env: dict | None = None, timeout: float = 120):
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "cavesim", *args], cwd=ROOT, text=True,
                          capture_output=True, timeout=timeout, env={**os.environ, **(env or {})})
    return done, time.monotonic() - started


def assert_one_clear_line(stderr: str) -> str:
    assert "Traceback" not in stderr
    (line,) = stderr.strip().splitlines()
    return line


def test_a_scene_that_does_not_load_stops_run_before_anything_starts(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[simulation]\ncapacity = -5\n")
    done, _ = cavesim("run", "--walls", "2", "--scene", str(bad), "--out", str(tmp_path / "o"))
    assert done.returncode == 2
    line = assert_one_clear_line(done.stderr)
    assert line.startswith("cavesim run: error: argument --scene: ")
    assert "simulation.capacity" in line and "-5" in line
    assert not (tmp_path / "o").exists(), "nothing was started, nothing was written"


def test_a_helicopter_model_that_is_not_gltf_stops_run_before_anything_starts(tmp_path):
    (tmp_path / "heli.glb").write_bytes(b"not a glTF file")
    scene = tmp_path / "scene.toml"
    scene.write_text(f'base = "{MINIMAL}"\n[helicopter]\nmass = 1000.0\nrotor_radius = 5.0\n'
                     'hub_height = 1.3\nmodel = "heli.glb"\n')
    done, _ = cavesim("run", "--walls", "1", "--scene", str(scene), "--out", str(tmp_path / "o"))
    assert done.returncode == 2
    line = assert_one_clear_line(done.stderr)
    assert line.startswith(f"cavesim run: error: argument --scene: {tmp_path / 'heli.glb'}: "
                           "not a .glb file: it begins b'not '"), line
    assert not (tmp_path / "o").exists()


def test_a_bad_cave_file_stops_run_before_anything_starts(tmp_path):
    cave = tmp_path / "cave.toml"
    cave.write_text('name = "x"\n[[wall]]\nname = "front"\n')
    done, _ = cavesim("run", "--cave", str(cave), "--scene", str(MINIMAL),
                      "--out", str(tmp_path / "o"))
    assert done.returncode == 2
    assert assert_one_clear_line(done.stderr).startswith("cavesim run: error: argument --cave: ")
    assert not (tmp_path / "o").exists()


def test_an_output_path_that_is_a_file_is_a_usage_error(tmp_path):
    out = tmp_path / "taken"
    out.write_text("a file")
    done, _ = cavesim("run", "--walls", "1", "--scene", str(MINIMAL), "--out", str(out))
    assert done.returncode == 2
    line = assert_one_clear_line(done.stderr)
    assert line == f"cavesim run: error: argument --out: {str(out)!r} is a file; give a folder " \
                   f"(a new one is made)"


def test_no_egl_driver_stops_run_before_anything_starts(tmp_path):
    done, _ = cavesim("run", "--walls", "2", "--scene", str(MINIMAL), "--out",
                      str(tmp_path / "o"),
                      env={"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"})
    assert done.returncode == 1
    line = assert_one_clear_line(done.stderr)
    assert line.startswith("cavesim: error: libEGL loads, but no EGL driver offers ")
    assert "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_nodes_that_cannot_start_stop_the_run_at_once_naming_the_wall_and_its_log(tmp_path):
    # every node is sent to an EGL device that does not exist (glcontext's own variable,
    # which the run does not look at); the master needs no GL
    done, seconds = cavesim("run", "--walls", "2", "--scene", str(MINIMAL), "--frames", "50",
                            "--out", str(tmp_path), env={"GLCONTEXT_DEVICE_INDEX": "99"})
    assert done.returncode == 1
    line = assert_one_clear_line(done.stderr)
    assert line.startswith("cavesim: error: wall ")
    assert "exited with code 1: cannot open a headless OpenGL context" in line
    wall = line.split()[3]
    assert line.endswith(f"(log: {tmp_path / 'logs' / wall}.log)")
    assert seconds < JOIN_TIMEOUT / 2, f"took {seconds:.1f} s"
    assert not _running(str(tmp_path)), "every process of the run has ended"


@pytest.mark.slow
def test_a_master_that_fails_mid_run_stops_the_nodes_at_once(tmp_path):
    config = MasterConfig(("front", "left"), MINIMAL, 50, f"ff{os.getpid()}")

    def break_at_frame_5(cluster, k):
        if k == 5:
            raise ClusterError("the master broke at frame 5")

    started = time.monotonic()
    with pytest.raises(ClusterError, match="the master broke at frame 5"):
        run_cluster(ClusterPlan(config, tmp_path), before_frame=break_at_frame_5)
    assert time.monotonic() - started < JOIN_TIMEOUT / 2
    assert not _running(str(tmp_path))


@pytest.mark.slow
def test_a_node_that_dies_mid_run_ends_the_run_naming_it(tmp_path):
    config = MasterConfig(("front", "left"), MINIMAL, 200, f"fd{os.getpid()}")

    def kill_left_at_frame_10(cluster, k):
        if k == 10:
            os.kill(cluster.nodes["left"].pid, signal.SIGKILL)  # not the harness's kill

    with pytest.raises(ClusterError) as raised:
        run_cluster(ClusterPlan(config, tmp_path), before_frame=kill_left_at_frame_10)
    assert str(raised.value) == ("wall left was killed by signal 9 (SIGKILL) "
                                 f"(log: {tmp_path / 'logs' / 'left.log'})")
    assert not _running(str(tmp_path))


def _running(marker: str) -> list[str]:
    """Command lines of live processes that mention `marker` (this run's output folder)."""
    found = []
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
            except OSError:
                continue
            if marker.encode() in command and int(pid) != os.getpid():
                found.append(command.decode(errors="replace"))
    return found


def test_last_error_prefers_cavesim_lines_and_strips_the_prefix(tmp_path):
    log = tmp_path / "node.log"
    log.write_text("2026 INFO up\ncavesim: error: the shader did not compile\n\n")
    assert last_error(log) == "the shader did not compile"
    log.write_text("Traceback (most recent call last):\n  File x\nValueError: odd\n")
    assert last_error(log) == "ValueError: odd"
    assert last_error(tmp_path / "missing.log").startswith("no log to read")


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _raise(args, console):
    raise ZeroDivisionError("x")


def test_a_bug_reaches_a_terminal_as_one_line_and_a_log_with_its_traceback(monkeypatch):
    monkeypatch.setattr(numerics, "stability", _raise)  # a handler with a bug
    monkeypatch.delenv(cli.TRACEBACK_VARIABLE, raising=False)
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert cli.main(["stability"]) == RUN_ERROR
    assert assert_one_clear_line(terminal.getvalue()) == (
        "cavesim: error: internal error, ZeroDivisionError: x (a bug; set "
        "CAVESIM_TRACEBACK=1 for the traceback)")
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    assert cli.main(["stability"]) == RUN_ERROR
    assert "Traceback" in log.getvalue()
    assert log.getvalue().strip().splitlines()[-1].startswith("cavesim: error: internal error")


@pytest.mark.parametrize(("args", "message"), [
    (["node", "--wall", "front", "--session", "a/b"],
     "cavesim node: error: argument --session: session must be 1-32 letters"),
    (["master", "--walls", "front", "--session", "a b"],
     "cavesim master: error: argument --session: session must be 1-32 letters"),
    (["run", "--session", "a/b"], "cavesim run: error: argument --session: session must be"),
    (["check", "--session", "a/b"], "cavesim check: error: argument --session: session must"),
    (["check", "--frames", "30", "--inject", "query-replay@25:front"],
     "query-replay@25:front makes its node diverge again at frame 35, after the last frame 30"),
    (["check", "--frames", "30", "--inject", "control-forgery@29"],
     "control-forgery@29 asks pause, reset, stop on frames 29 to 31, after the last frame 30"),
    (["doctor", "--session", "x.y"], "cavesim doctor: error: argument --session: session"),
    (["run", "--cave", "no/such/cave.toml"], "argument --cave: no CAVE file"),
    (["node", "--node", "ws9", "--cave", "config/cave/flex4.toml"],
     "argument --node: 'ws9' draws no wall of config/cave/flex4.toml; its nodes are front, "
     "left, right, floor"),
    (["node", "--node", "ws1", "--cave", "config/cave/flex4.toml", "--draws", "front,roof"],
     "argument --draws: config/cave/flex4.toml has no wall 'roof'; its walls are front"),
    (["node", "--node", "ws1", "--draws", "front"], "argument --draws: walls of a CAVE"),
    (["run", "--group-by", "projector"], "argument --group-by: invalid choice: 'projector'"),
    (["check", "--cave", "config/cave/flex4.toml", "--inject", "bitflip@5:ws2"],
     "node 'ws2' of bitflip@5:ws2 is not one of the nodes front, left, right, floor"),
])
def test_bad_names_and_files_are_usage_errors(args, message):
    done, _ = cavesim(*args)
    assert done.returncode == 2
    assert message in assert_one_clear_line(done.stderr)


@pytest.mark.parametrize("command", [["master", "--walls", "front"], ["node", "--wall", "front"],
                                     ["tracker", "--dtrack", "5000"]])
@pytest.mark.parametrize(("text", "says"), [("{ this is not json5", "expected array"),
                                            ('{"mode": "bogus"}', "unknown variant `bogus`")])
def test_a_zenoh_config_that_does_not_parse_is_one_line_before_anything_starts(
        tmp_path, command, text, says):
    config = tmp_path / "zenoh.json5"
    config.write_text(text)
    done, _ = cavesim(*command, "--config", str(config))
    assert done.returncode == 2
    line = assert_one_clear_line(done.stderr)
    assert f"--config {config}: not a usable zenoh config" in line and says in line
    assert ".rs:" not in line  # zenoh's Rust source location is not for a user


def test_an_endpoint_zenoh_cannot_listen_on_is_one_line(tmp_path):
    done, _ = cavesim("master", "--walls", "front", "--listen", "tcp/192.0.2.1:7447",
                      "--scene", str(MINIMAL))
    assert done.returncode == 1
    line = assert_one_clear_line(done.stderr)
    assert "cannot open a zenoh session (--listen ['tcp/192.0.2.1:7447']" in line


def test_a_join_timeout_is_one_line_naming_the_flag(tmp_path):
    done, _ = cavesim("master", "--walls", "front", "--scene", str(MINIMAL),
                      "--join-timeout", "0.5", "--listen", "tcp/127.0.0.1:0")
    assert done.returncode == 1
    line = assert_one_clear_line(done.stderr)
    assert "walls ['front'] did not join within 0.5 s (--join-timeout)" in line
