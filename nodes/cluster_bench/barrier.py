"""`cavesim bench --cluster`: what keeping the walls in lock-step costs, on loopback.

Three figures, each held to its target (benchmark figures, not timed tests):

- the barrier round trip per frame with 2, 4 and 8 wall nodes of a tiny scene: the master's
  `barrier_ms` from the run's report.json (publish frame k -> every node's report of k in),
  beside the CPU every process spent per frame (`metered_run.CpuMeter`);
- the swap barrier's skew with 2 and 4 walls live in windows (`swap.py`);
- the lock-step cost: a 4-wall cluster's frames per second against the same four
  simulations stepped back to back in one process on one GL context,
  cost = 1 - cluster_fps / back_to_back_fps.

The cluster runs keep their report.json, frames.log and logs under OUT/cluster/; the
figures go to OUT/cluster.json and OUT/cluster.md.
"""

from __future__ import annotations

import importlib.metadata
import operator
import os
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import moderngl
import numpy as np
from rich.console import Console

from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import load_scene
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.context import create_context, describe
from cavesim.tools.bench.display import progress_bar
from cavesim.tools.bench.measure import BenchError
from nodes.arguments import wall_names
from nodes.cluster_bench.metered_run import Tick, cluster_run
from nodes.cluster_bench.swap import SWAP_WALL_COUNTS, measure_swap
from nodes.cluster_bench.tables import show, write_reports

BARRIER_SCENE = "config/scenes/minimal.toml"  # a few hundred to 2,000 live particles
LOCKSTEP_SCENE = "config/scenes/dust_devil.toml"
LOCKSTEP_WALLS = 4
FRAME_DT = 1 / 60  # the master's dt and clock seed: back to back steps the cluster's frames
CLOCK_SEED = 0


@dataclass(frozen=True)
class ClusterTarget:
    name: str
    comparison: str  # "<" or "<="
    bound: float
    meaning: str
    most_nodes: int | None = None  # the bound holds for runs of at most this many nodes
    spare_cores: int | None = None  # judged only with at least nodes + this many cores

    def judge(self, measured: float, nodes: int, cores: int, floor_ms: float | None = None
              ) -> dict[str, object]:
        """The verdict on `measured` in a run of `nodes` nodes on `cores` cores: `met` is
        None, with `why`, where there are too few cores to hold it to the bound."""
        verdict: dict[str, object] = {"met": {"<": operator.lt, "<=": operator.le}[
            self.comparison](measured, self.bound)}
        if self.spare_cores is not None and cores < nodes + self.spare_cores:
            verdict = {"met": None, "why": f"{cores} cores < {nodes} nodes + "
                                           f"{self.spare_cores}: the CPU floor is "
                                           f"{floor_ms} ms"}
        return {"name": self.name, "meaning": self.meaning, "comparison": self.comparison,
                "target": self.bound, "measured": measured, "nodes": nodes, **verdict}


# The lock-step's targets on loopback
BARRIER_TARGETS = (  # the first whose most_nodes holds a run's node count judges it
    ClusterTarget("barrier_p99_ms", "<=", 1.0, "barrier round trip per frame, 99th "
                  "percentile, with 2 nodes", most_nodes=2, spare_cores=2),
    ClusterTarget("barrier_p99_ms", "<=", 2.0, "barrier round trip per frame, 99th "
                  "percentile, with 3 to 8 nodes", most_nodes=8, spare_cores=2),
)
NODE_CPU = ClusterTarget("node_cpu_ms", "<=", 0.3, "CPU per frame of the busiest node of the "
                         "2-node run of the tiny scene (user + system, every thread)")
SWAP_SKEW = ClusterTarget("swap_skew_p99_ms", "<", 1.0, "latest - earliest swap of a frame "
                          "across the walls, 99th percentile")
LOCKSTEP_COST = ClusterTarget("lockstep_cost", "<=", 0.10, "throughput lost to lock-step: "
                              "1 - cluster fps / back-to-back fps")
TARGETS = (*BARRIER_TARGETS, NODE_CPU, SWAP_SKEW, LOCKSTEP_COST)

NOTES = (
    "barrier round trip: the master's time from publishing frame k to holding every node's "
    "report of k; it includes each node's step and checksum of the tiny scene, not only "
    "the network",
    "one node's step + checksum: the tiny scene's frames stepped and checksummed by one "
    "ParticleSystem in this process, the node's own share of each round trip",
    "the master and every node run on this machine and share its cores: cpu ms/frame is "
    "what the master and all nodes spent together per frame (user + system, every thread), "
    "and cpu floor = that / the cores, under which no round trip can average",
    "swap skew: the walls of a swap-locked run in small windows on one X server (no vsync); "
    "each node sends the monotonic time its swap returned, one clock on one machine; the "
    "master sends frame k + 1 only once every wall swapped k (the frame lock)",
    "cluster fps: frames / seconds of the master's frame loop once every wall has joined "
    "(report.json frames_per_second); back-to-back fps: frames / seconds of one process "
    "stepping and checksumming the four ParticleSystems on one GL context, after building them",
    "both step the same frames: dt 1/60 and random transforms drawn from PCG64(0), the "
    "master's default clock, so both must end on the same checksum",
    "lockstep_cost = 1 - cluster_fps / back_to_back_fps; negative: the cluster was faster. "
    "On llvmpipe one process steps on about one core (the GS/TF passes run on the calling "
    "thread), while the cluster's processes overlap on all of them",
)


def barrier_target(nodes: int) -> ClusterTarget | None:
    """The barrier target that judges a run of `nodes` nodes (None past the last)."""
    return next((t for t in BARRIER_TARGETS if nodes <= t.most_nodes), None)


def run_cluster_bench(barrier_scene: Path, lockstep_scene: Path, cave: Path,
                      node_counts: list[int], frames: int, out_dir: Path,
                      console: Console) -> dict[str, object]:
    """Measure, print the tables and targets, write cluster.json and cluster.md; the swap
    runs show walls of `cave`."""
    runs_dir = out_dir / "cluster"
    with progress_bar(console) as progress:
        runs_total = len(node_counts) + len(SWAP_WALL_COUNTS) + 3
        task = progress.add_task("cluster bench", total=frames * runs_total)
        done = 0

        def ticker(label: str) -> Tick:
            nonlocal done
            start, done = done, done + frames

            def tick(k: int) -> None:
                progress.update(task, completed=start + k, description=label)
            return tick

        runs = [cluster_run(barrier_scene, wall_names(n), frames, runs_dir / f"barrier-{n}",
                            ticker(f"barrier, {n} nodes")) for n in node_counts]
        swap = measure_swap(barrier_scene, cave, frames, runs_dir, ticker)
        cluster = cluster_run(lockstep_scene, wall_names(LOCKSTEP_WALLS), frames,
                              runs_dir / f"lockstep-{LOCKSTEP_WALLS}",
                              ticker(f"lock-step, {LOCKSTEP_WALLS} walls"))
        ctx = create_context()
        try:
            gl = describe(ctx)
            one_node = _in_process(ctx, barrier_scene, 1, frames, ticker("one node's work"))
            back_to_back = _in_process(ctx, lockstep_scene, LOCKSTEP_WALLS, frames,
                                       ticker(f"back to back, {LOCKSTEP_WALLS} systems"))
        finally:
            ctx.release()
    report = build_report({"scene": str(barrier_scene), "runs": runs, "one_node": one_node},
                          swap, cluster, back_to_back, gl, frames)
    show(report, console)
    for path in write_reports(report, out_dir):
        console.print(f"wrote {path}", markup=False, highlight=False, soft_wrap=True)
    return report


def _in_process(ctx: moderngl.Context, scene_path: Path, systems: int, frames: int,
                tick: Tick) -> dict[str, object]:
    """`systems` copies of the scene stepped one after another per frame, each checksummed."""
    scene = load_scene(scene_path)
    clock = np.random.Generator(np.random.PCG64(CLOCK_SEED))
    copies = []
    try:
        copies = [ParticleSystem(ctx, scene) for _ in range(systems)]
        disagreements, times = 0, []
        for k in range(1, frames + 1):
            started = time.perf_counter()
            inputs = FrameInput(FRAME_DT, draw_transform(clock, scene.random_texture_size))
            digests = set()
            for system in copies:
                system.step(inputs)
                digests.add(system.checksum().digest)
            times.append(time.perf_counter() - started)
            disagreements += len(digests) > 1
            tick(k)
        live = copies[0].live_count
        if (error := ctx.error) != "GL_NO_ERROR":
            raise BenchError(f"GL reported {error} while stepping {systems} systems in process")
    finally:
        for system in copies:
            system.release()
    ms = np.array(times) * 1e3
    return {"systems": systems, "scene": str(scene_path), "frames": frames,
            "seconds": float(sum(times)), "frames_per_second": frames / sum(times),
            "frame_ms": {"p50": float(np.percentile(ms, 50)), "p99": float(np.percentile(ms, 99))},
            "live_particles_last": live, "frames_with_unequal_systems": disagreements,
            "final_checksum": digests.pop()}


def build_report(barrier: dict, swap: dict, cluster: dict, back_to_back: dict,
                 gl: dict[str, str], frames: int) -> dict[str, object]:
    """`barrier`: {"scene", "runs": one per node count, "one_node": a node's work in process};
    `swap`: `measure_swap`'s {"runs": ...} or {"skipped": why}."""
    cluster_fps, serial_fps = cluster["frames_per_second"], back_to_back["frames_per_second"]
    lockstep = {"walls": cluster["nodes"], "cluster": cluster, "back_to_back": back_to_back,
                "cluster_fps": cluster_fps, "back_to_back_fps": serial_fps,
                "lockstep_cost": 1 - cluster_fps / serial_fps,
                "same_final_checksum": cluster["final_checksum"]
                == back_to_back["final_checksum"]}
    cores = os.cpu_count() or 1
    for run in barrier["runs"]:
        cpu = run["cpu_ms_per_frame"]
        run["cpu_floor_ms"] = None if cpu is None else round(cpu["total"] / cores, 3)
    targets = [barrier_target(run["nodes"]).judge(run["barrier_ms"]["p99"], run["nodes"],
                                                  cores, run["cpu_floor_ms"])
               for run in barrier["runs"] if barrier_target(run["nodes"]) is not None]
    targets += [NODE_CPU.judge(max(run["cpu_ms_per_frame"]["nodes"].values()), 2, cores)
                for run in barrier["runs"] if run["nodes"] == 2 and run["cpu_ms_per_frame"]]
    targets += [SWAP_SKEW.judge(run["swap"]["skew_ms"]["p99"], run["nodes"], cores)
                for run in swap.get("runs", ()) if run["swap"]["skew_ms"]["p99"] is not None]
    targets.append(LOCKSTEP_COST.judge(lockstep["lockstep_cost"], cluster["nodes"], cores))
    return {
        "command": "bench --cluster",
        "gl": gl,
        "cpu_count": os.cpu_count(),
        "versions": {"eclipse-zenoh": importlib.metadata.version("eclipse-zenoh"),
                     "numpy": np.__version__},
        "frames": frames,
        "barrier": barrier,
        "swap": swap,
        "lockstep": lockstep,
        "targets": targets,
        "notes": list(NOTES),
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }


# -- the human side: tables, target lines, markdown ---------------------------------------
