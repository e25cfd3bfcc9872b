"""Starting and stopping wall-node and master processes on this machine.

Every child runs in a session of its own, so a Ctrl-C reaches the launcher alone and the
launcher stops the children in order: the master first (it tells the nodes to STOP),
then whatever node is still there after a grace period.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from nodes.faults import Fault

GRACE_SECONDS = 10.0


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

    def kill_node(self, wall: str) -> None:
        process = self.nodes.pop(wall)
        process.kill()
        process.wait()

    def stop(self) -> None:
        """Interrupt the master, then end every node; nothing is left running."""
        if self.master is not None and self.master.poll() is None:
            self.master.send_signal(signal.SIGINT)
            _wait_or_kill(self.master)
        for process in self.nodes.values():
            _wait_or_kill(process, interrupt=True)

    def __enter__(self) -> LocalCluster:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def _wait_or_kill(process: subprocess.Popen, interrupt: bool = False) -> None:
    try:
        process.wait(timeout=GRACE_SECONDS)
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
