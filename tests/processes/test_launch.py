"""deploy/launch.sh: the commands it would run from a hosts file, its answer to bad hosts
files, and real runs on this machine (one `cavesim run`, and the hosts path with `via=`).
"""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import time
from pathlib import Path

import pytest
from requirements import CAVESIM

from cavesim.core.limits import DEFAULT_MASTER_PORT
from nodes.launch.launcher import free_port

ROOT = Path(__file__).parents[2]
LAUNCH = ROOT / "deploy" / "launch.sh"
MINIMAL = "config/scenes/minimal.toml"
SSH = ["ssh", "-tt", "-o", "BatchMode=yes"]

HOSTS = """\
# a CAVE of three walls
master 10.0.0.1:7500   # the master's host and port

node front hostA
node left  hostB via="ip netns exec left"
node floor 10.0.0.4 via=
"""


def launch(*args: str, env: dict | None = None, timeout: float = 30,
           **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([str(LAUNCH), *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})}, **kwargs)


def hosts_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "hosts"
    path.write_text(text)
    return path


def commands(stdout: str) -> dict[str, list[str]]:
    """The dry run's commands as argv lists, keyed 'mkdir', 'master' or the wall's name."""
    found = {}
    for line in stdout.splitlines():
        if line.startswith("#"):
            continue
        argv = shlex.split(line)
        if "mkdir" in argv:
            found["mkdir"] = argv
        elif "master" in argv:
            found["master"] = argv
        else:
            found[argv[argv.index("--node") + 1]] = argv
    return found


def flag(argv: list[str], name: str) -> str:
    return argv[argv.index(name) + 1]


def prefix(argv: list[str], remote: str = "cavesim") -> list[str]:
    """What comes before the cavesim command: the host's `via`."""
    return argv[:argv.index(remote)]


@pytest.fixture
def dry_run(tmp_path):
    done = launch("--hosts", str(hosts_file(tmp_path, HOSTS)), "--dry-run", "--frames", "30",
                  "--scene", MINIMAL, "--out", "runs/a", "--session", "cave1",
                  "--keys", "/etc/cavesim/keys")
    assert done.returncode == 0, done.stderr
    return commands(done.stdout)


def test_master_listens_on_its_port_and_names_the_walls_in_file_order(dry_run):
    master = dry_run["master"]
    assert prefix(master) == [*SSH, "10.0.0.1"]
    assert master[len(SSH) + 2] == "master"
    assert flag(master, "--listen") == "tcp/0.0.0.0:7500"
    assert flag(master, "--walls") == "front,left,floor"
    assert flag(master, "--frames") == "30"
    assert flag(master, "--report") == "runs/a/report.json"
    assert flag(master, "--frame-log") == "runs/a/frames.log"
    assert dry_run["mkdir"] == [*SSH, "10.0.0.1", "mkdir", "-p", "runs/a"]


def test_every_node_connects_to_the_master_through_its_via(dry_run):
    assert [w for w in dry_run if w not in ("mkdir", "master")] == ["front", "left", "floor"]
    vias = {"front": [*SSH, "hostA"], "left": ["ip", "netns", "exec", "left"], "floor": []}
    for wall, via in vias.items():
        node = dry_run[wall]
        assert prefix(node) == via
        assert node[len(via) + 1] == "node"
        assert flag(node, "--connect") == "tcp/10.0.0.1:7500"
        assert flag(node, "--listen") == "tcp/0.0.0.0:0"


def test_scene_session_and_keys_reach_every_process(dry_run):
    for argv in (dry_run["master"], dry_run["front"], dry_run["left"], dry_run["floor"]):
        assert flag(argv, "--scene") == MINIMAL
        assert flag(argv, "--session") == "cave1"
    assert flag(dry_run["master"], "--key-file") == "/etc/cavesim/keys/master.key"
    for wall in ("front", "left", "floor"):  # nodes never get the master's signing key
        assert flag(dry_run[wall], "--key-file") == f"/etc/cavesim/keys/wall-{wall}.key"


def test_default_port_ipv6_master_and_remote_cavesim(tmp_path):
    hosts = hosts_file(tmp_path, "master [fd00::1]\nnode front [fd00::2]\n")
    done = launch("--hosts", str(hosts), "--dry-run", "--insecure",
                  env={"CAVESIM_REMOTE": "/opt/cavesim/bin/cavesim"})
    assert done.returncode == 0, done.stderr
    found = commands(done.stdout)
    remote = "/opt/cavesim/bin/cavesim"
    assert prefix(found["master"], remote) == [*SSH, "fd00::1"]
    assert flag(found["master"], "--listen") == f"tcp/0.0.0.0:{DEFAULT_MASTER_PORT}"
    assert prefix(found["front"], remote) == [*SSH, "fd00::2"]
    assert flag(found["front"], "--connect") == f"tcp/[fd00::1]:{DEFAULT_MASTER_PORT}"
    assert "--key-file" not in found["front"]


def test_without_hosts_it_runs_cavesim_run_here():
    done = launch("--dry-run", "--walls", "3", "--frames", "20", "--scene", MINIMAL)
    assert done.returncode == 0, done.stderr
    argv = shlex.split(done.stdout.splitlines()[-1])
    assert argv[:2] == [str(CAVESIM), "run"]
    assert flag(argv, "--walls") == "3" and flag(argv, "--frames") == "20"
    assert flag(argv, "--scene") == MINIMAL


def test_display_runs_the_cave_live_here_and_on_every_host(tmp_path):
    done = launch("--dry-run", "--cave", "config/cave/flex4.toml", "--display")
    assert done.returncode == 0, done.stderr
    argv = shlex.split(done.stdout.splitlines()[-1])
    assert flag(argv, "--cave") == "config/cave/flex4.toml" and "--display" in argv
    assert "--walls" not in argv
    done = launch("--hosts", str(hosts_file(tmp_path, HOSTS)), "--dry-run", "--insecure", "--cave",
                  "/opt/cave.toml", "--display")
    assert done.returncode == 0, done.stderr
    found = commands(done.stdout)
    for wall in ("front", "left", "floor"):
        assert flag(found[wall], "--cave") == "/opt/cave.toml" and "--display" in found[wall]
    assert "--display" not in found["master"]


def test_nodes_of_several_walls_here_and_on_the_hosts(tmp_path):
    done = launch("--dry-run", "--cave", "config/cave/flex4.toml", "--group-by", "gpu")
    assert done.returncode == 0, done.stderr
    assert flag(shlex.split(done.stdout.splitlines()[-1]), "--group-by") == "gpu"
    done = launch("--hosts", str(hosts_file(tmp_path, "master m\nnode ws1 a\nnode ws2 b\n")),
                  "--dry-run", "--insecure", "--cave", "/opt/cave.toml", "--display")
    assert done.returncode == 0, done.stderr
    found = commands(done.stdout)
    assert flag(found["master"], "--walls") == "ws1,ws2"
    assert flag(found["ws2"], "--node") == "ws2"
    assert flag(found["ws2"], "--cave") == "/opt/cave.toml"


def test_mixed_hardware_reaches_the_master_and_every_node_or_cavesim_run(tmp_path):
    done = launch("--hosts", str(hosts_file(tmp_path, HOSTS)), "--dry-run", "--insecure",
                  "--mixed-hardware")
    assert done.returncode == 0, done.stderr
    found = commands(done.stdout)
    assert all("--mixed-hardware" in found[p] for p in ("master", "front", "left", "floor"))
    done = launch("--dry-run", "--walls", "2", "--mixed-hardware")
    assert done.returncode == 0, done.stderr
    assert "--mixed-hardware" in shlex.split(done.stdout.splitlines()[-1])


def test_max_lag_reaches_the_master_or_cavesim_run(tmp_path):
    done = launch("--hosts", str(hosts_file(tmp_path, HOSTS)), "--dry-run", "--insecure",
                  "--max-lag", "0.1")
    assert done.returncode == 0, done.stderr
    found = commands(done.stdout)
    assert flag(found["master"], "--max-lag") == "0.1"
    assert not any("--max-lag" in found[wall] for wall in ("front", "left", "floor"))
    done = launch("--dry-run", "--walls", "2", "--max-lag", "0.25")
    assert done.returncode == 0, done.stderr
    assert flag(shlex.split(done.stdout.splitlines()[-1]), "--max-lag") == "0.25"


def test_display_needs_a_cave():
    done = launch("--dry-run", "--display")
    assert done.returncode == 2
    assert "argument --display: needs --cave FILE" in done.stderr


@pytest.mark.parametrize("text, line, message", [
    ("node front a\nnode left b\n", None, "no 'master HOST[:PORT]' line"),
    ("master a\nnode front b\n\nmaster c\n", 4, "a second master (the first is line 1)"),
    ("master a\nnode front b\n# x\nnode front c\n", 4, "node 'front' appears twice"),
    ("master a\nrouter b\nnode front c\n", 2, "unknown role 'router'"),
    ("master a:70000\nnode front b\n", 1, "port must be 1..65535"),
    ("master a\nnode front\n", 2, "expected 'node NAME HOST [via=COMMAND]'"),
    ("master a\nnode fr;ont b\n", 2, "node name must be"),
    ("master a\n", None, "no 'node NAME HOST' line"),
])
def test_a_bad_hosts_file_exits_2_naming_the_line(tmp_path, text, line, message):
    hosts = hosts_file(tmp_path, text)
    done = launch("--hosts", str(hosts), "--dry-run")
    assert done.returncode == 2
    where = f"{hosts}:{line}: " if line else f"{hosts}: "
    assert f"launch.sh: error: {where}{message}" in done.stderr, done.stderr
    assert done.stdout == ""


def test_hosts_without_keys_refuse_to_run_unsigned_unless_insecure(tmp_path):
    hosts = str(hosts_file(tmp_path, HOSTS))
    done = launch("--hosts", hosts, "--dry-run")
    assert done.returncode == 2 and "messages cross a network unsigned; give --keys DIR" \
        in done.stderr and done.stdout == "", done.stderr
    assert launch("--hosts", hosts, "--dry-run", "--insecure").returncode == 0


@pytest.mark.parametrize("args, message", [
    (["--walls", "2"], "argument --walls: 2 walls, but"),
    (["--frames", "0"], "argument --frames: expected a number >= 1"),
    (["--out", "a b"], "--out 'a b': only letters"),
    (["--out", "README.md"], "argument --out: 'README.md' is a file; give a folder"),
    (["--session", "a.b"], "argument --session"),
    (["--bogus"], "unknown argument --bogus"),
    (["--group-by", "gpu"], "argument --group-by: only without --hosts"),
    (["--max-lag", "1s"], "argument --max-lag: expected seconds (e.g. 0.1), got '1s'"),
])
def test_bad_arguments_exit_2(tmp_path, args, message):
    done = launch("--hosts", str(hosts_file(tmp_path, HOSTS)), "--dry-run", "--insecure", *args)
    assert done.returncode == 2 and message in done.stderr, done.stderr


def read_report(out: Path) -> dict:
    return json.loads((out / "report.json").read_text())


@pytest.mark.slow
@pytest.mark.requires("venv")
def test_a_local_run_writes_a_clean_report(tmp_path):
    out = tmp_path / "run"
    done = launch("--walls", "2", "--frames", "30", "--out", str(out), "--scene", MINIMAL,
                  "--session", f"launch{os.getpid()}", timeout=120)
    assert done.returncode == 0, done.stderr
    report = read_report(out)
    assert report["frames"] == 30 and report["nodes"] == ["front", "left"]
    assert report["divergences"] == [] and report["stalls"] == []


def local_hosts(tmp_path: Path, walls=("front", "left")) -> Path:
    """A hosts file whose processes all run on this machine (empty via=)."""
    lines = [f"master 127.0.0.1:{free_port()} via="]
    lines += [f"node {wall} 127.0.0.1 via=" for wall in walls]
    return hosts_file(tmp_path, "\n".join(lines) + "\n")


def running(session: str) -> list[str]:
    """Command lines of cavesim processes of `session` still running."""
    found = subprocess.run(["pgrep", "-af", "--", f"--session {session} "], capture_output=True,
                           text=True)
    return found.stdout.splitlines()


@pytest.mark.slow
@pytest.mark.requires("venv")
def test_a_hosts_file_run_on_this_machine(tmp_path):
    out, session = tmp_path / "run", f"hosts{os.getpid()}"
    done = launch("--hosts", str(local_hosts(tmp_path)), "--insecure", "--frames", "30",
                  "--out", str(out),
                  "--scene", MINIMAL, "--session", session, timeout=120,
                  env={"CAVESIM_REMOTE": str(CAVESIM)})
    assert done.returncode == 0, done.stderr
    report = read_report(out)
    assert report["frames"] == 30 and report["divergences"] == []
    assert (out / "frames.log").stat().st_size > 0
    assert {p.name for p in (out / "logs").iterdir()} == {"front.log", "left.log"}
    assert running(session) == []


@pytest.mark.slow
@pytest.mark.requires("venv")
def test_ctrl_c_stops_the_master_and_every_node(tmp_path):
    out, session = tmp_path / "run", f"sigint{os.getpid()}"
    argv = [str(LAUNCH), "--hosts", str(local_hosts(tmp_path)), "--insecure", "--frames",
            "1000000",
            "--out", str(out), "--scene", MINIMAL, "--session", session]
    # its own process group, with SIGINT at its default (as a terminal's Ctrl-C finds it)
    process = subprocess.Popen(argv, cwd=ROOT, env={**os.environ, "CAVESIM_REMOTE": str(CAVESIM)},
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 60
        log = out / "frames.log"
        while not (log.exists() and log.stat().st_size > 2000):  # some frames went by
            assert time.monotonic() < deadline and process.poll() is None, "no frames"
            time.sleep(0.1)
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 130
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert "interrupted: stopping the master" in process.stderr.read()
    report = read_report(out)
    assert report["interrupted"] and 0 < report["frames"] < 1000000
    assert running(session) == []
