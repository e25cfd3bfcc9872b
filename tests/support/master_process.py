"""`cavesim master` as a process of its own beside a LocalCluster's nodes (the multi-host
path: `cavesim run` runs its master in process), for the tests that need it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from nodes.launch.launcher import LocalCluster


def spawn_master(cluster: LocalCluster, walls: tuple[str, ...], frames: int,
                 extra=(), key_file: Path | None = None) -> subprocess.Popen:
    """Start the master of `cluster`'s session (signing with `key_file`, a master.key, when
    given): JSON progress lines on its stdout, its log in OUT/logs/master.log, report.json
    and frames.log in OUT."""
    args = ["master", "--walls", ",".join(walls), "--frames", str(frames),
            "--scene", str(cluster.scene), "--session", cluster.session, "--verbose",
            *(["--key-file", str(key_file)] if key_file else []),
            "--listen", cluster.master_endpoint, "--progress",
            "--report", str(cluster.out / "report.json"),
            "--frame-log", str(cluster.out / "frames.log"), *extra]
    (cluster.out / "logs").mkdir(parents=True, exist_ok=True)
    with open(cluster.log_path("master"), "ab") as log:
        return subprocess.Popen([sys.executable, "-m", "cavesim", *args], stdout=subprocess.PIPE,
                                stderr=log, stdin=subprocess.DEVNULL, start_new_session=True)
