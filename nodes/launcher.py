"""Starting, watching and stopping wall-node and master processes on this machine.

Every child runs in a session of its own, so a Ctrl-C reaches the launcher alone and the
launcher stops the children in order: the master first (it tells the nodes to STOP),
then whatever node is still there after a grace period. While the master runs, the
launcher watches every child: one that exits early stops the others at once, and the
error names that process, its own last error line and its log.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from cavesim.errors import ClusterError
from nodes.faults import Fault

GRACE_SECONDS = 10.0
WATCH_SECONDS = 0.1  # how often the children are looked at while the master is quiet
INTERRUPTED = 130  # the master's exit code after a Ctrl-C
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
    key_file: Path | None = None
    nodes: dict[str, subprocess.Popen] = field(default_factory=dict)
    master: subprocess.Popen | None = None

    @property
    def master_endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.port}"

    def _common(self) -> list[str]:
        args = ["--scene", str(self.scene), "--session", self.session, "--verbose"]
        return args + (["--key-file", str(self.key_file)] if self.key_file else [])

    def _spawn(self, name: str, args: list[str], stdout=subprocess.DEVNULL) -> subprocess.Popen:
        logs = self.out / "logs"
        logs.mkdir(parents=True, exist_ok=True)
        with open(logs / f"{name}.log", "ab") as log:
            return subprocess.Popen([sys.executable, "-m", "cavesim", *args], stdout=stdout,
                                    stderr=log, stdin=subprocess.DEVNULL,
                                    start_new_session=True)

    def start_node(self, wall: str, faults: tuple[Fault, ...] = (), extra=()) -> None:
        args = ["node", "--wall", wall, *self._common(), "--connect", self.master_endpoint,
                "--listen", "tcp/127.0.0.1:0", *extra]
        for fault in faults:
            args += ["--inject", str(fault)]
        self.nodes[wall] = self._spawn(wall, args)

    def start_master(self, walls: tuple[str, ...], frames: int, extra=()) -> subprocess.Popen:
        args = ["master", "--walls", ",".join(walls), "--frames", str(frames), *self._common(),
                "--listen", self.master_endpoint, "--progress", "--report",
                str(self.out / "report.json"), "--frame-log", str(self.out / "frames.log"),
                *extra]
        self.master = self._spawn("master", args, stdout=subprocess.PIPE)
        return self.master

    def log_path(self, name: str) -> Path:
        return self.out / "logs" / f"{name}.log"

    def follow(self, on_progress: Callable[[dict], None]) -> int:
        """Relay the master's progress lines until it ends; its exit code.

        A node that exits before the master has sent its last frame, or a master that
        fails, stops every child at once and raises ClusterError naming that process.
        """
        lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=_read_lines, args=(self.master.stdout, lines),
                         daemon=True).start()
        finished = False  # the master has sent its last frame: nodes may leave now
        while (line := _next(lines)) is not None:
            if line:
                update = json.loads(line)
                finished = update["frame"] >= update["frames"]
                on_progress(update)
            early = [(w, p) for w, p in self.nodes.items()
                     if p.poll() is not None and (p.returncode != 0 or not finished)]
            if early:
                self.stop(at_once=True)
                raise ClusterError(self.failure(*early[0]))
        code = self.master.wait()
        if code not in (0, INTERRUPTED):
            self.stop(at_once=True)
            raise ClusterError(self.failure("master", self.master))
        return code

    def failure(self, name: str, process: subprocess.Popen) -> str:
        """One line: which process ended, with what code, its own error, and its log."""
        what = "the master" if name == "master" else f"wall {name}"
        log = self.log_path(name)
        return (f"{what} exited with code {process.returncode}: {last_error(log)} "
                f"(log: {log})")

    def kill_node(self, wall: str) -> None:
        process = self.nodes.pop(wall)
        process.kill()
        process.wait()

    def stop(self, at_once: bool = False) -> None:
        """Interrupt the master, then end every node; nothing is left running.

        `at_once`: interrupt the nodes right away too (after a failure the master's STOP
        may never reach them) instead of giving them a grace period to leave.
        """
        if self.master is not None and self.master.poll() is None:
            self.master.send_signal(signal.SIGINT)
            _wait_or_kill(self.master, patience=GRACE_SECONDS)
        for process in self.nodes.values():
            _wait_or_kill(process, patience=0.0 if at_once else GRACE_SECONDS, interrupt=True)

    def __enter__(self) -> LocalCluster:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def _read_lines(stream, lines: queue.Queue) -> None:
    for line in stream:
        lines.put(line)
    lines.put(None)


def _next(lines: queue.Queue) -> str | None:
    """The master's next line, "" if none came within WATCH_SECONDS, None at its end."""
    try:
        return lines.get(timeout=WATCH_SECONDS)
    except queue.Empty:
        return ""


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


def _wait_or_kill(process: subprocess.Popen, patience: float, interrupt: bool = False) -> None:
    """Give `process` `patience` seconds to end; then (if `interrupt`) a SIGINT and half the
    grace period; then SIGKILL to its whole session."""
    try:
        process.wait(timeout=patience)
        return
    except subprocess.TimeoutExpired:
        pass
    if interrupt:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=GRACE_SECONDS / 2)
            return
        except subprocess.TimeoutExpired:
            pass
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
