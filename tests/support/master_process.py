"""`cavesim master` as a process of its own beside a LocalCluster's nodes (the multi-host
path: `cavesim run` runs its master in process), for the tests that need it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from nodes.launch.launcher import LocalCluster


def spawn_master(cluster: LocalCluster, walls: tuple[str, ...], frames: int,
                 extra=(), key_file: Path | None = None, out: Path | None = None,
                 network: tuple[str, ...] | None = None) -> subprocess.Popen:
    """Start the master of `cluster`'s session (signing with `key_file`, a master.key, when
    given): JSON progress lines on its stdout, its log in OUT/logs/master.log, report.json
    and frames.log in OUT (`out`, by default the cluster's folder). It listens on the
    cluster's endpoint unless `network` gives its --listen and --connect flags (a second
    master beside a running one)."""
    out = out or cluster.out
    network = network or ("--listen", cluster.master_endpoint)
    args = ["master", "--walls", ",".join(walls), "--frames", str(frames),
            "--scene", str(cluster.scene), "--session", cluster.session, "--verbose",
            *(["--key-file", str(key_file)] if key_file else []), *network, "--progress",
            "--report", str(out / "report.json"), "--frame-log", str(out / "frames.log"),
            *extra]
    (out / "logs").mkdir(parents=True, exist_ok=True)
    with open(out / "logs" / "master.log", "ab") as log:
        return subprocess.Popen([sys.executable, "-m", "cavesim", *args], stdout=subprocess.PIPE,
                                stderr=log, stdin=subprocess.DEVNULL, start_new_session=True)


def progress_until(master: subprocess.Popen, frame: int) -> int:
    """Read the master's JSON progress lines until `frame`; the last frame read."""
    for line in master.stdout:
        if json.loads(line)["frame"] >= frame:
            return frame
    raise AssertionError(f"the master ended before frame {frame}")


def running(session: str) -> list[str]:
    """Command lines of cavesim processes of `session` still running."""
    found = subprocess.run(["pgrep", "-af", "--", f"--session {session} "],
                           capture_output=True, text=True)
    return found.stdout.splitlines()
