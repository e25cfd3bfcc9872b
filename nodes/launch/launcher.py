"""Starting, watching and stopping wall-node processes on this machine.

Every child runs in a session of its own, so a Ctrl-C reaches the launcher alone (and its
in-process master, which tells the nodes to STOP); whatever is still there at the end gets
SIGTERM, and TERMINATE_SECONDS later its whole session SIGKILL: after an interruption or a
failure that is at once, so that no node outlives the launcher by more than that. While a
run needs them, a watcher thread looks at every child: one that exits becomes a
`ProcessEnded` event for the master, naming that process, its own last error line and its
log.
"""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

from cavesim.core.wire.credentials import OPERATOR, WALL, member_file
from cavesim.tools.signals import held
from nodes.faults import Fault
from nodes.master.events import Event, ProcessEnded

PROC = Path("/proc")  # what the kernel says of each process

GRACE_SECONDS = 10.0  # s the nodes have to leave on the master's STOP at the end of a run
TERMINATE_SECONDS = 1.0  # s a node has after SIGTERM before its session is killed
WATCH_SECONDS = 0.1  # how often the watcher looks at the children
_LOG_TAIL_BYTES = 8192


def free_port() -> int:
    """A TCP port on loopback that nothing listens on right now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@dataclass
class LocalCluster:
    """Child processes of one session on loopback; a context manager that cleans up."""

    scene: Path
    out: Path
    session: str
    port: int = field(default_factory=free_port)
    keys: Path | None = None  # a folder of the walls' key files (wall-WALL.key) ...
    operators: frozenset[str] = frozenset()  # ... and of these nodes' operator-NODE.key
    expected_nodes: int = 1  # how many nodes share this machine's cores
    drawing: frozenset[str] = frozenset()  # walls whose nodes draw pictures
    nodes: dict[str, subprocess.Popen] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)  # nodes vs the watcher

    @property
    def master_endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.port}"

    def _common(self) -> list[str]:
        return ["--scene", str(self.scene), "--session", self.session, "--verbose"]

    def key_arguments(self, wall: str) -> list[str]:
        """--key-file of `wall`'s own key, when the cluster has keys, and the
        --operator-key-file of a node that is an operator too (a preview)."""
        if self.keys is None:
            return []
        operator = ["--operator-key-file", str(self.keys / member_file(OPERATOR, wall))] \
            if wall in self.operators else []
        return ["--key-file", str(self.keys / member_file(WALL, wall)), *operator]

    def _spawn(self, name: str, args: list[str],
               environment: dict[str, str] | None = None) -> subprocess.Popen:
        logs = self.out / "logs"
        logs.mkdir(parents=True, exist_ok=True)
        with open(logs / f"{name}.log", "ab") as log:
            return subprocess.Popen([sys.executable, "-m", "cavesim", *args],
                                    stdout=subprocess.DEVNULL, stderr=log,
                                    stdin=subprocess.DEVNULL, start_new_session=True,
                                    env=environment)

    def node_environment(self, wall: str) -> dict[str, str]:
        """`wall`'s node's environment. Mesa's llvmpipe gives each process as many
        rasterizer (and compute) threads as there are cores. A node that never draws only
        steps and checksums, and with more node processes than cores those threads only hand
        work to each other: it gets its share of the cores, none below two (measured on 2
        cores: the 4-node barrier p99 4.7 ms with them, 2.2-3.0 ms without). A drawing node
        keeps them: they draw the brownout demo's walls 15% faster (28 against 24 frames/s).
        A GPU driver ignores the variable; a user's own setting wins."""
        if wall in self.drawing:
            return dict(os.environ)
        share = (os.cpu_count() or 1) // max(1, self.expected_nodes)
        return {"LP_NUM_THREADS": str(share if share > 1 else 0), **os.environ}

    def start_node(self, wall: str, faults: tuple[Fault, ...] = (), extra=()) -> None:
        args = ["node", "--wall", wall, *self._common(), *self.key_arguments(wall),
                "--connect", self.master_endpoint,
                "--listen", "tcp/127.0.0.1:0", *extra]
        for fault in faults:
            args += ["--inject", str(fault)]
        process = self._spawn(wall, args, self.node_environment(wall))
        with self._lock:
            self.nodes[wall] = process

    def log_path(self, name: str) -> Path:
        return self.out / "logs" / f"{name}.log"

    @contextmanager
    def watch(self, events: queue.Queue[Event]) -> Iterator[None]:
        """While inside, post a ProcessEnded event for every node process that exits."""
        done = threading.Event()

        def look() -> None:
            reported: set[int] = set()
            while not done.wait(WATCH_SECONDS):
                with self._lock:
                    ended = [(w, p) for w, p in self.nodes.items()
                             if p.pid not in reported and p.poll() is not None]
                for wall, process in ended:
                    reported.add(process.pid)
                    events.put(ProcessEnded(wall, process.returncode,
                                            self.failure(wall, process)))

        watcher = threading.Thread(target=look, daemon=True)
        watcher.start()
        try:
            yield
        finally:
            done.set()
            watcher.join()

    def failure(self, wall: str, process: subprocess.Popen) -> str:
        """One line: which node ended, and how: killed by a signal (it could write no error
        of its own), or its exit code, its own error and its log."""
        log = self.log_path(wall)
        if process.returncode < 0:
            return f"wall {wall} was killed by {signal_name(-process.returncode)} (log: {log})"
        return (f"wall {wall} exited with code {process.returncode}: {last_error(log)} "
                f"(log: {log})")

    def kill_node(self, wall: str) -> None:
        """Kill `wall`'s process on purpose (a fault): the watcher does not report it."""
        with self._lock:
            process = self.nodes.pop(wall)
            process.kill()
        process.wait()

    def stop(self, at_once: bool = False) -> None:
        """End every node; nothing is left running.

        The nodes leave on the master's STOP, within GRACE_SECONDS; `at_once` (a failure or
        an interruption: the STOP may never have reached them, and a node still starting
        does not take it) ends them right away. A stopping signal waits until they are gone.
        """
        with held():
            processes = list(self.nodes.values())
            _wait_all(processes, 0.0 if at_once else GRACE_SECONDS)
            left = [process for process in processes if process.poll() is None]
            for process in left:
                _signal_session(process, signal.SIGTERM)
            _wait_all(left, TERMINATE_SECONDS)
            for process in left:
                if process.poll() is None:
                    _signal_session(process, signal.SIGKILL)
                    process.wait()

    def __enter__(self) -> LocalCluster:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.stop(at_once=exc_type is not None)


def signal_name(number: int) -> str:
    """"signal 9 (SIGKILL)", or "signal 77" for a number the system does not name."""
    try:
        return f"signal {number} ({signal.Signals(number).name})"
    except ValueError:
        return f"signal {number}"


def last_error(log: Path) -> str:
    """A process's own last error line from its log (cavesim's one-line errors first)."""
    try:
        with open(log, "rb") as file:
            file.seek(max(0, file.seek(0, os.SEEK_END) - _LOG_TAIL_BYTES))
            tail = file.read().decode(errors="replace").splitlines()
    except OSError as e:
        return f"no log to read ({e.strerror or e})"
    lines = [line.strip() for line in tail if line.strip()]
    ours = [line for line in lines if line.startswith("cavesim") and "error" in line]
    if not (ours or lines):
        return "it wrote no error"
    line = (ours or lines)[-1]
    return line.removeprefix("cavesim: error: ")


def _wait_all(processes: list[subprocess.Popen], seconds: float) -> None:
    """Wait until every one of `processes` has ended, or `seconds` have passed."""
    deadline = time.monotonic() + seconds
    for process in processes:
        try:
            process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass


def _signal_session(process: subprocess.Popen, number: int) -> None:
    """Send signal `number` to every process of `process`'s session (its children too; it
    leads the session, and is not reaped yet, so its id is not another's)."""
    with suppress(ProcessLookupError):  # it has just ended
        os.killpg(process.pid, number)


def resident_mb(pid: int, peak: bool = False) -> float | None:
    """Process `pid`'s resident memory (VmRSS; with `peak`, its highest so far: VmHWM) in
    MB of 10^6 bytes (None: not readable)."""
    try:
        status = (PROC / str(pid) / "status").read_text()
    except OSError:
        return None
    field = "VmHWM:" if peak else "VmRSS:"
    for line in status.splitlines():
        if line.startswith(field):  # "VmRSS:     123456 kB", the kernel's kB being KiB
            return int(line.split()[1]) * 1024 / 1e6
    return None
