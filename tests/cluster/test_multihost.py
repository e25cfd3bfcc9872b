"""The cluster on separate network hosts, healthy and under a bad network.

A master host and three node hosts are network namespaces on one switch (tests/support/netns.py);
deploy/launch.sh starts the cluster on them over Zenoh TCP with
config/zenoh/multihost.json5, the master pacing frames in real time as on a CAVE. Each
network condition is a run of its own on a fresh network:

- healthy;
- delay: 20 ms added each way between the master and every node, by a delaying TCP relay
  (tests/support/delay_relay.py) on the switch at its own address: the hosts file names the relay
  as the master's host, so the nodes dial it and it dials the master. Gossip cannot route
  around it: a node already has a transport to the master's zenoh id through the relay,
  and zenoh keeps one per peer. Node-to-node traffic (resync snapshots) is not delayed;
- loss: every host drops 5% of the packets it receives (iptables `statistic`);
- cut: one node host's switch port goes down for 2 s mid-run, then up again.

Every run must end with exit status 0, no divergence, every frame 1..F in the frame log and
all walls agreeing; the cut-off node must be found lost (liveliness) and rejoin by resync.
The barrier figures (p50/p99/max per condition) are printed as a table and written to
out/multihost.json. Needs root, `ip netns` and .venv; skipped otherwise, failed with
--require-tools (CI runs as root).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import pytest
from netns import Network, remove_stale
from requirements import CAVESIM

from cavesim.core.framelog import read_frame_log
from cavesim.core.limits import DEFAULT_MASTER_PORT
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.key_files import write_key_files
from cavesim.core.wire.network import RUNTIME_THREADS

ROOT = Path(__file__).parents[2]
LAUNCH = ROOT / "deploy" / "launch.sh"
RELAY = ROOT / "tests" / "support" / "delay_relay.py"
ZENOH_CONFIG = "config/zenoh/multihost.json5"
SCENE = "config/scenes/minimal.toml"
WALLS = ("front", "left", "right")
MASTER_PORT = DEFAULT_MASTER_PORT
FIGURES_JSON = ROOT / "out" / "multihost.json"
pytestmark = pytest.mark.xdist_group("multihost")  # one figures table of every run


@dataclass(frozen=True)
class Condition:
    name: str
    frames: int  # at 60 frames/s in real time, unless the network holds the barrier longer
    delay_ms: float = 0.0  # added each way between the master and every node
    loss: float = 0.0  # share of the packets every host drops
    cut: str | None = None  # the wall whose host is cut off ...
    cut_at: int = 0  # ... once this frame is logged ...
    cut_seconds: float = 0.0  # ... for this long


CONDITIONS = (
    Condition("healthy", 300),
    Condition("delay 20 ms", 200, delay_ms=20),
    Condition("loss 5%", 200, loss=0.05),
    Condition("cut 2 s", 600, cut="left", cut_at=120, cut_seconds=2.0),
)
FIGURES: dict[str, dict] = {}


def run_id(condition: Condition) -> str:
    return f"{os.getpid()}{condition.name[0]}"


@pytest.fixture(scope="module", autouse=True)
def figures_table(request):
    """After the runs: the barrier figures per condition, as a table and as JSON."""
    yield
    if not FIGURES:
        return
    lines = ["", "multi-host cluster, 3 walls + master, minimal scene, real time:",
             f"{'condition':<12} {'frames':>6} {'s':>6} {'p50 ms':>8} {'p99 ms':>8} "
             f"{'max ms':>8}  events"]
    for name, f in FIGURES.items():
        events = ", ".join(f"{k} {len(f[k])}" for k in ("stalls", "losses", "joins", "resyncs")
                           if f[k]) or "-"
        b = f["barrier_ms"]
        lines.append(f"{name:<12} {f['frames']:>6} {f['seconds']:>6.1f} {b['p50']:>8.2f} "
                     f"{b['p99']:>8.2f} {b['max']:>8.1f}  {events}")
    FIGURES_JSON.parent.mkdir(exist_ok=True)
    FIGURES_JSON.write_text(json.dumps(FIGURES, indent=2) + "\n")
    lines.append(f"(written to {FIGURES_JSON.relative_to(ROOT)})")
    capture = request.config.pluginmanager.getplugin("capturemanager")
    with capture.global_and_fixture_disabled():  # into the CI log, -s or not
        print("\n".join(lines), flush=True)


@pytest.fixture(params=CONDITIONS, ids=lambda c: c.name.split()[0])
def condition(request) -> Condition:
    return request.param


@pytest.fixture
def network(condition):
    """Four hosts on one switch, removed afterwards however the test ends."""
    remove_stale()
    net = Network(("master", *WALLS), run_id(condition))
    try:
        with net:
            yield net
    finally:
        assert net.leftovers() == [], "network namespaces left behind"


def frames_logged(path: Path) -> int:
    """Frames in a frame log the master may be writing right now (a torn tail is not one)."""
    count = 0
    try:
        _, frames = read_frame_log(path)
        for _ in frames:
            count += 1
    except (OSError, ValueError):
        pass
    return count


class Cut(threading.Thread):
    """Pull `wall`'s cable once frame `at` is logged, plug it back after `seconds`."""

    def __init__(self, net: Network, wall: str, at: int, seconds: float, log: Path) -> None:
        super().__init__(daemon=True)
        self.net, self.wall, self.at, self.seconds, self.log = net, wall, at, seconds, log
        self.done = threading.Event()
        self.cut_frame: int | None = None  # frames logged when the cable was pulled ...
        self.back_frame: int | None = None  # ... and when it was plugged back
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            while not self.done.is_set() and frames_logged(self.log) < self.at:
                self.done.wait(0.05)
            if self.done.is_set():
                return
            self.cut_frame = frames_logged(self.log)
            self.net.set_link(self.wall, False)
            self.done.wait(self.seconds)  # the length of the fault, not a wait for readiness
            self.net.set_link(self.wall, True)
            self.back_frame = frames_logged(self.log)
        except BaseException as e:  # reported by the test, not lost in a thread
            self.error = e


def start_relay(net: Network, delay_ms: float) -> subprocess.Popen:
    """The delaying relay on the switch: nodes dial it, it dials the master."""
    relay = net.popen(None, [sys.executable, str(RELAY),
                             "--listen", f"{net.switch_address}:{MASTER_PORT}",
                             "--target", f"{net.address('master')}:{MASTER_PORT}",
                             "--delay-ms", str(delay_ms)],
                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = relay.stdout.readline()  # printed once it listens; '' if it died
    assert line.startswith("listening"), f"relay did not start: {line!r} {relay.stderr.read()}"
    return relay


def hosts_file(net: Network, master_host: str, path: Path) -> Path:
    lines = [f'master {master_host}:{MASTER_PORT} via="{net.via("master")}"']
    lines += [f'node {wall} {net.address(wall)} via="{net.via(wall)}"' for wall in WALLS]
    path.write_text("\n".join(lines) + "\n")
    return path


def logs(out: Path) -> str:
    """The tails of the master's and the nodes' logs, for a failure message."""
    parts = []
    for log in [out / "master.log", *sorted((out / "logs").glob("*.log"))]:
        if log.exists():
            parts.append(f"--- {log.name}\n" + "\n".join(log.read_text().splitlines()[-15:]))
    return "\n".join(parts)


def run(net: Network, condition: Condition, out: Path) -> tuple[dict, Cut | None]:
    """One cluster run under `condition`; the master's report and the cut (if any)."""
    keys = out / "keys"
    write_key_files(keys, generate(), WALLS)
    relay = start_relay(net, condition.delay_ms) if condition.delay_ms else None
    if condition.loss:
        net.drop_share(condition.loss)
    master_host = net.switch_address if relay else net.address("master")
    command = [str(LAUNCH), "--hosts", str(hosts_file(net, master_host, out / "hosts")),
               "--frames", str(condition.frames), "--scene", SCENE, "--out", str(out),
               "--session", f"mh{run_id(condition)}", "--keys", str(keys),
               "--config", ZENOH_CONFIG, "--realtime"]
    env = {**os.environ, "CAVESIM_REMOTE": str(CAVESIM), "ZENOH_RUNTIME": RUNTIME_THREADS}
    cut = None
    with open(out / "master.log", "wb") as master_log:
        launch = subprocess.Popen(command, cwd=ROOT, env=env, stdin=subprocess.DEVNULL,
                                  stdout=master_log, stderr=subprocess.STDOUT,
                                  start_new_session=True)
    try:
        if condition.cut:
            cut = Cut(net, condition.cut, condition.cut_at, condition.cut_seconds,
                      out / "frames.log")
            cut.start()
        try:
            status = launch.wait(timeout=180)
        except subprocess.TimeoutExpired:
            pytest.fail(f"{condition.name}: the cluster did not finish in 180 s\n{logs(out)}")
        assert status == 0, f"{condition.name}: launch.sh exited with {status}\n{logs(out)}"
    finally:
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGKILL)  # the rest dies with the namespaces
        if cut is not None:
            cut.done.set()
            cut.join(timeout=10)
        if relay is not None:
            relay.kill()
            relay.communicate()
    return json.loads((out / "report.json").read_text()), cut


def test_launch_passes_the_zenoh_config_and_real_time_to_the_hosts(tmp_path):
    hosts = tmp_path / "hosts"
    hosts.write_text('master 10.9.9.1 via="ip netns exec m"\nnode front 10.9.9.2 via=\n')
    done = subprocess.run([str(LAUNCH), "--hosts", str(hosts), "--config", ZENOH_CONFIG,
                           "--realtime", "--insecure", "--dry-run"], cwd=ROOT,
                          capture_output=True,
                          text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    master, node = [argv for argv in map(str.split, done.stdout.splitlines())
                    if "cavesim" in argv and argv[argv.index("cavesim") + 1] in ("master", "node")]
    for argv in (master, node):
        assert argv[argv.index("--config") + 1] == ZENOH_CONFIG
    assert "--realtime" in master and "--realtime" not in node
    here = subprocess.run([str(LAUNCH), "--config", ZENOH_CONFIG, "--dry-run"], cwd=ROOT,
                          capture_output=True, text=True, timeout=30)
    assert here.returncode == 2 and "--config: only with --hosts" in here.stderr


@pytest.mark.slow
@pytest.mark.requires("netns", "venv")
def test_cluster_on_network_hosts(network, condition, tmp_path):
    report, cut = run(network, condition, tmp_path)
    settings = {"delay_ms_each_way": condition.delay_ms, "packet_loss": condition.loss,
                "cut": condition.cut and f"{condition.cut} for {condition.cut_seconds:g} s"}
    FIGURES[condition.name] = {"network": settings, **{
        key: report[key] for key in ("frames", "seconds", "frames_per_second", "barrier_ms",
                                     "stalls", "losses", "joins", "resyncs")}}
    if cut is not None:
        FIGURES[condition.name]["network"].update(pulled_at_frame=cut.cut_frame,
                                                  back_at_frame=cut.back_frame)
    where = f"{condition.name}:\n{json.dumps(FIGURES[condition.name])}"

    assert report["frames"] == condition.frames and not report["interrupted"], where
    assert report["divergences"] == [], where
    _, logged = read_frame_log(tmp_path / "frames.log")
    assert [f.message.frame for f in logged] == list(range(1, condition.frames + 1))
    assert report["final"] == {"frame": condition.frames, "members": list(WALLS),
                               "all_walls_in": True, "agree": True, "lost": []}, where
    assert not report["rejected_messages"]["master"], where
    assert not any(report["rejected_messages"]["nodes"].values()), where

    if condition.delay_ms:  # the relay is on the path both ways: frame out, report back
        assert report["barrier_ms"]["p50"] >= 2 * condition.delay_ms, where
    if not condition.cut:
        for key in ("stalls", "losses", "joins", "resyncs"):
            assert report[key] == [], f"{key} on a network that lost no host\n{where}"
        return

    assert cut.error is None and cut.back_frame is not None, f"the cut did not happen\n{where}"
    losses = report["losses"]
    assert losses and {loss["node"] for loss in losses} == {condition.cut}, where
    assert all(loss["detected_by"] == "liveliness" for loss in losses), where
    # any stall waits on the cut-off node alone: the others kept the barrier moving
    assert all(set(s["nodes"]) == {condition.cut} for s in report["stalls"]), where
    lost_at = losses[0]["frame"]
    assert lost_at >= cut.cut_frame, where
    assert [j["node"] for j in report["joins"]] == [condition.cut], where
    assert report["joins"][0]["frame"] > lost_at, where
    healed = [r for r in report["resyncs"] if r["ok"]]
    assert [r["node"] for r in healed] == [condition.cut], where
    assert healed[0]["frame"] == report["joins"][0]["frame"], where
