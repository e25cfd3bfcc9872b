"""`cavesim bench --soak`: a long cluster run as fast as the walls go, watching memory.

The master (this process) and one node process per wall run many frames of a small
scene with no frame pacing (the master's clock is not real-time unless asked). Before the
first frame, after every `every`-th frame and after the last, once every wall has
reported that frame, the resident memory of each process (VmRSS in /proc/PID/status) is
read. What the run records is bounded (`cavesim.core.bounded`), so a column that keeps
rising is a leak to find, not a record filling up. The run's report.json, frames.log and
logs go to OUT/soak/; the samples and what they add up to go to OUT/soak.json.
"""

from __future__ import annotations

import importlib.metadata
import os
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

from rich.console import Console

from cavesim.tools.bench.display import progress_bar
from nodes.arguments import wall_names
from nodes.cluster_bench.metered_run import cluster_run
from nodes.cluster_bench.soak_table import sample_line, show, write_report
from nodes.launch.launcher import resident_mb

SOAK_SCENE = "config/scenes/minimal.toml"
SOAK_FRAMES = 100_000
SOAK_WALLS = 4
SOAK_EVERY = 10_000
MASTER = "master"  # the process name of the master (this process) in the samples


class MemorySampler:
    """A `FrameMeter`: the resident memory of the master and of each node process at frame
    0 (every wall joined, nothing stepped), every `every`-th frame and the last."""

    def __init__(self, frames: int, every: int,
                 on_sample: Callable[[dict], None] = lambda sample: None) -> None:
        self.frames, self.every, self.on_sample = frames, every, on_sample
        self.pids: dict[str, int] = {}
        self.samples: list[dict] = []
        self.started = 0.0

    def before_frame(self, cluster, k: int) -> None:
        if k == 1:  # the nodes are up: the master sends frame 1 only once every wall joined
            self.pids = {MASTER: os.getpid(),
                         **{wall: node.pid for wall, node in cluster.nodes.items()}}
            self.started = time.monotonic()
            self._sample(0)

    def after_frame(self, k: int) -> None:
        if k % self.every == 0 or k == self.frames:
            self._sample(k)

    def _sample(self, k: int) -> None:
        rss = {name: resident_mb(pid) for name, pid in self.pids.items()}
        sample = {"frame": k, "seconds": round(time.monotonic() - self.started, 3),
                  "rss_mb": {name: None if mb is None else round(mb, 3)
                             for name, mb in rss.items()}}
        self.samples.append(sample)
        self.on_sample(sample)


def run_soak(scene: Path, walls: int, frames: int, every: int, out_dir: Path,
             console: Console) -> dict[str, object]:
    """Run the soak, print the samples' table, write OUT/soak.json; the report."""
    names = wall_names(walls)
    with progress_bar(console) as progress:
        task = progress.add_task(f"soak, {walls} walls", total=frames)

        def announce(sample: dict) -> None:  # a line per sample stays when the bar is gone
            progress.console.print(sample_line(sample), markup=False, highlight=False)

        sampler = MemorySampler(frames, every, announce)
        run = cluster_run(scene, names, frames, out_dir / "soak",
                          lambda k: progress.update(task, completed=k), meters=(sampler,))
    report = build_report(run, sampler.samples, every)
    show(report, console)
    path = write_report(report, out_dir)
    console.print(f"wrote {path}", markup=False, highlight=False, soft_wrap=True)
    return report


def growth_mb(first: dict, last: dict) -> dict[str, float | None]:
    """Per process: its resident memory in sample `last` less that in sample `first`."""
    return {name: None if mb is None or last["rss_mb"].get(name) is None
            else round(last["rss_mb"][name] - mb, 3) for name, mb in first["rss_mb"].items()}


def build_report(run: dict, samples: list[dict], every: int) -> dict[str, object]:
    """soak.json's content from `cluster_run`'s figures and the sampler's samples."""
    renderers = sorted({gpu["renderer"] for gpu in run["gpus"].values()})
    return {
        "command": "bench --soak",
        "scene": run["scene"],
        "walls": run["nodes"],
        "frames": run["frames"],
        "seconds": run["seconds"],  # the master's frame loop, every wall joined
        "frames_per_second": run["frames_per_second"],
        "sample_every": every,
        "renderer": ", ".join(renderers) or None,
        "samples": samples,
        "growth_mb": growth_mb(samples[0], samples[-1]),
        # from the frame `every` sample: without what the first frames allocate once
        "steady_growth_mb": growth_mb(samples[1], samples[-1]) if len(samples) > 2 else None,
        "divergences": run["divergences"],
        "stalls": run["stalls"],
        "barrier_ms": run["barrier_ms"],
        "final_checksum": run["final_checksum"],
        "gpus": run["gpus"],
        "cpu_count": os.cpu_count(),
        "versions": {"eclipse-zenoh": importlib.metadata.version("eclipse-zenoh")},
        "report": run["report"],
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }
