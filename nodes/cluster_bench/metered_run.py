"""One cluster run of `cavesim bench --cluster` (or `--soak`) and what it cost: the
master's report figures, the CPU the master and every node process spent per frame, and
whatever else a `FrameMeter` watches between frames (the soak's memory samples).

The CPU figure answers where a barrier's time goes when the nodes share the machine: all
processes together need `total` CPU milliseconds per frame, so on `cores` cores no round
trip can average under total / cores, however fast the network. The processes live in
nodes/, so this module imports nodes.* only inside the function that starts them.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

from cavesim.tools.bench.measure import BenchError
from nodes.launch.launcher import PROC

Tick = Callable[[int], None]  # called with the number of frames done so far in one run
WARM_FRAMES = 2  # frames before the CPU meter starts: the first ones compile and allocate


class FrameMeter(Protocol):
    """Watches a cluster run: before each frame k is made (nodes in `cluster.nodes`, a
    `LocalCluster`), and once every member has reported k and the vote is done."""

    def before_frame(self, cluster, k: int) -> None: ...

    def after_frame(self, k: int) -> None: ...


def process_cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of process `pid`, all its threads (None: no /proc)."""
    try:
        stat = (PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2:].split()  # after "pid (comm) ": state is fields[0]
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class CpuMeter:
    """CPU seconds of this process (the master) and of each node process, between the
    start of frame WARM_FRAMES + 1 and the start of the last frame."""

    def __init__(self, frames: int) -> None:
        self.first, self.last = WARM_FRAMES + 1, frames
        self.marks: list[dict[str, float | None]] = []

    def before_frame(self, cluster, k: int) -> None:
        if k in (self.first, self.last) and self.first < self.last:
            mark = {wall: process_cpu_seconds(node.pid) for wall, node in cluster.nodes.items()}
            self.marks.append({"master": time.process_time(), **mark})

    def after_frame(self, k: int) -> None:
        pass

    def per_frame_ms(self) -> dict[str, object] | None:
        """{"master": ms, "nodes": {wall: ms}, "total": ms} per frame, or None when not
        measured (a short run, or no /proc)."""
        if len(self.marks) != 2 or None in (*self.marks[0].values(), *self.marks[1].values()):
            return None
        start, end = self.marks
        frames = self.last - self.first
        ms = {name: round((end[name] - start[name]) / frames * 1e3, 3) for name in start}
        master = ms.pop("master")
        return {"master": master, "nodes": ms, "total": round(master + sum(ms.values()), 3)}


def cluster_run(scene: Path, walls: Sequence[str], frames: int, run_dir: Path, tick: Tick,
                node_args: tuple[str, ...] = (), draws: bool = False,
                meters: Sequence[FrameMeter] = ()) -> dict[str, object]:
    """One cluster run to the end (every node started with `node_args`; `draws`: they draw
    pictures; `meters` watch it beside the CPU meter), its report.json kept in `run_dir`;
    its figures."""
    from cavesim.core.framelog import FRAME_LOG, read_frame_log
    from nodes.launch.cluster import ClusterPlan, run_cluster
    from nodes.master.process import MasterConfig

    run_dir.mkdir(parents=True, exist_ok=True)
    config = MasterConfig(tuple(walls), scene, frames,
                          f"bench-{os.getpid()}-{run_dir.name}", frame_log=run_dir / FRAME_LOG)
    meter = CpuMeter(frames)
    watching = (meter, *meters)

    def before_frame(cluster, k: int) -> None:
        for watcher in watching:
            watcher.before_frame(cluster, k)

    def after_frame(k: int, live: int) -> None:
        for watcher in watching:
            watcher.after_frame(k)
        tick(k)

    plan = ClusterPlan(config, run_dir, node_args=dict.fromkeys(walls, node_args),
                       drawing=frozenset(walls) if draws else frozenset())
    record = run_cluster(plan, after_frame, before_frame)
    if record.interrupted or record.frames != frames:
        raise BenchError(f"the {len(walls)}-node cluster run ended after {record.frames} of "
                         f"{frames} frames; see {run_dir / 'logs'}")
    report = record.summary()
    report_path = run_dir / "report.json"
    report_path.write_text(json.dumps(report, indent=2) + "\n")
    *_, last = read_frame_log(run_dir / FRAME_LOG)[1]
    return {"nodes": len(walls), "scene": str(scene), "frames": report["frames"],
            "seconds": report["seconds"], "frames_per_second": report["frames_per_second"],
            "barrier_ms": report["barrier_ms"], "cpu_ms_per_frame": meter.per_frame_ms(),
            "frame_cost_ms": report["frame_cost_ms"],
            "live_particles_max": report["live_particles"]["max"],
            "divergences": record.divergences.total, "stalls": record.stalls.total,
            "swap": report["swap"], "final_checksum": last.digest, "gpus": report["gpus"],
            "report": str(report_path)}
