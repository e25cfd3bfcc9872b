"""`cavesim bench --resync`: what healing a one-particle bitflip costs, the full snapshot
against the delta resync, what confirming the state by a second wall costs, and what the
forensics' history ring costs per frame.

Each way runs as a real cluster on loopback (`cavesim check`'s harness): three wall nodes,
each its own process and GL context, hold the same state of N particles (a scene whose
burst fills the pool in frame 1 and whose particles live on); at frame 3 one node flips a
bit of one particle, the master names it, its forensics run, and the node resyncs from the
first of the others, confirmed by the second — by full snapshot (`--resync full`) or by
delta. The node's log line gives the bytes it received and sent, its own resync time and
the confirmation's; the master's record the time from its RESYNC command to the node's
verified report. The confirmation's parts (`confirmation_cost.py`) and the history ring's cost
are measured in this process: a checksum of the same N-particle state, then the GPU copy of
its fold-1 items into the ring, waited for.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import re
import statistics
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cavesim.core.digest.history import HISTORY_FRAMES
from cavesim.core.digest.shape import ITEM_WORDS, plan
from cavesim.core.errors import CavesimError
from cavesim.core.output import writing
from nodes.cluster_bench.confirmation_cost import confirmation_cost

RESYNC_PARTICLES = 1_000_000
FLIP_FRAME = 3  # the bitflip's frame: the pool is full from frame 1
RING_FRAMES = 20  # timed frames of the history ring's copy
MODES = ("full", "delta")
WALLS, FLIPPED = ("front", "left", "right"), "right"  # right heals from front, left confirms
_RESYNCED = re.compile(r"resynced to frame \d+ from \w+: (?P<how>.*), (?P<bytes>\d+) bytes, "
                       r"(?P<seconds>[\d.]+) s; confirmed by (?P<confirmer>\w+) "
                       r"\((?P<digests>\d+) digest\(s\), (?P<confirm_seconds>[\d.]+) s\)")
SCENE = """# bench --resync: {particles} particles from frame 1 on, living for the whole run
name = "resync"
[simulation]
capacity = {particles}
seed = 5
integrator = "semi_implicit_euler"
[[particle_class]]
name = "grain"
diameter = 1e-3
density = 2000.0
[[emitter]]
name = "burst"
position = [0.0, 0.0, 1.0]
extent = [4.0, 4.0, 2.0]
rate = {rate:.1f}
speed = 1.0
direction = [0.0, 0.0, 1.0]
spread_angle = 90.0
lifetime = [1000.0, 1000.0]
particle_class = "grain"
[forces]
gravity = [0.0, 0.0, -9.81]
"""


class ResyncBenchError(CavesimError, RuntimeError):
    """A bench run did not heal the bitflip the way it was to be measured."""


def run_resync_bench(particles: int, out_dir: Path, console: Console) -> dict:
    """Measure both ways and the ring, print the table, write OUT/resync.json."""
    from cavesim.core.scene import load_scene

    folder = out_dir / "resync"
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "scene.toml"
    scene.write_text(SCENE.format(particles=particles, rate=particles * 60.0))
    ways = []
    for mode in MODES:
        with console.status(f"{mode} resync of {particles:,} particles, three nodes on "
                            f"loopback"):
            ways.append(_one_way(scene, mode, folder / mode))
        way = ways[-1]
        console.print(f"{mode} resync: {way['bytes']:,} bytes, node {way['node_seconds']} s, "
                      f"confirmed by {way['confirmer']} in {way['confirm_seconds']} s",
                      markup=False, highlight=False)
    with console.status("the confirmation's parts, in this process"):
        confirmation = confirmation_cost(load_scene(scene), console)
    with console.status("history ring per frame"):
        ring = ring_cost(load_scene(scene))
    report = {
        "command": "bench --resync", "particles": particles, "flip_frame": FLIP_FRAME,
        "how": "a cluster on loopback: the master in this process, three wall nodes as "
               "processes of their own (cavesim check's harness), HMAC-signed traffic; "
               "the second healthy wall confirms the resync",
        "ways": ways,
        "bytes_ratio": round(ways[0]["bytes"] / ways[1]["bytes"], 1),
        "node_seconds_ratio": round(ways[0]["node_seconds"] / ways[1]["node_seconds"], 1),
        "confirmation": confirmation,
        "history_ring": ring,
        "renderer": ways[0]["renderer"], "cpu_count": os.cpu_count(),
        "versions": {"eclipse-zenoh": importlib.metadata.version("eclipse-zenoh")},
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    show(report, console)
    path = out_dir / "resync.json"
    with writing(path):
        path.write_text(json.dumps(report, indent=2) + "\n")
    console.print(f"wrote {path}", markup=False, highlight=False, soft_wrap=True)
    return report


def _one_way(scene: Path, mode: str, out: Path) -> dict:
    """One cluster run whose bitflipped node heals by `mode`: its figures."""
    from nodes.check.harness import CheckPlan, run_check
    from nodes.faults import Fault

    plan = CheckPlan(WALLS, scene, FLIP_FRAME + 1, (Fault("bitflip", FLIP_FRAME, FLIPPED),), out,
                     session=f"resync{os.getpid()}{mode}", barrier_timeout=60.0, resync=mode)
    report = run_check(plan)
    resyncs = report["run"]["resyncs"]
    line = next((m for m in map(_RESYNCED.search, (out / "logs" / f"{FLIPPED}.log")
                                .read_text().splitlines()) if m), None)
    if len(resyncs) != 1 or not resyncs[0]["ok"] or line is None \
            or (mode == "delta") != line["how"].startswith("by delta"):
        raise ResyncBenchError(f"the {mode} run did not heal the bitflip by {mode} resync: "
                               f"see {out / 'logs'}")
    (outcome,) = report["faults"]
    (divergence,) = report["run"]["divergences"]
    forensics = json.loads((out / divergence["forensics"]["file"]).read_text())
    return {"mode": mode, "how": line["how"], "bytes": int(line["bytes"]),
            "node_seconds": float(line["seconds"]), "confirmer": line["confirmer"],
            "confirm_digests": int(line["digests"]),
            "confirm_seconds": float(line["confirm_seconds"]),
            "master_seconds": round(resyncs[0]["seconds"], 3),
            "localised": outcome["localisation"]["exact"],
            "forensics_seconds": divergence["forensics"]["seconds"],
            "forensics_bytes": forensics["bytes_fetched"],
            "renderer": report["run"]["gpus"].get(FLIPPED, {}).get("renderer")}


def ring_cost(scene) -> dict:
    """Per frame at the scene's capacity, all live: the checksum, and the copy of its
    fold-1 items into the history ring, each waited for (medians)."""
    from cavesim.gpu.engine import ParticleSystem
    from cavesim.gpu.gl.context import create_context
    from cavesim.tools.bench.workload import preload

    ctx = create_context()
    system = ParticleSystem(ctx, scene)
    try:
        system.write_particles(preload(scene, scene.capacity, None))
        checksum, ring = [], []
        for frame in range(1, RING_FRAMES + 1):
            started = time.perf_counter()
            system.checksum()
            copied = time.perf_counter()
            system.keep_history(frame)
            ctx.finish()
            checksum.append(copied - started)
            ring.append(time.perf_counter() - copied)
            system.bench_particle_pass(np.float32(0.0))  # a new state: the next checksum runs
    finally:
        system.release()
    items = plan(scene.capacity, len(scene.emitters)).items[1]
    return {"frames": RING_FRAMES, "checksum_ms": round(statistics.median(checksum) * 1e3, 3),
            "ring_copy_ms": round(statistics.median(ring) * 1e3, 4),
            "bytes_per_frame": items * ITEM_WORDS[1] * 4,
            "ring_bytes": HISTORY_FRAMES * items * ITEM_WORDS[1] * 4,
            "ring_frames": HISTORY_FRAMES}


def show(report: dict, console: Console) -> None:
    table = Table(title=f"bench --resync: one flipped bit of {report['particles']:,} "
                        f"particles, three nodes on loopback ({report['renderer']})")
    for column in ("resync", "bytes", "node s", "confirm s", "master s", "what moved",
                   "localised"):
        table.add_column(column, justify="right")
    for way in report["ways"]:
        table.add_row(way["mode"], f"{way['bytes']:,}", f"{way['node_seconds']:.2f}",
                      f"{way['confirm_seconds']:.3f}", f"{way['master_seconds']:.3f}",
                      way["how"], "yes" if way["localised"] else "NO")
    console.print(table)
    ring = report["history_ring"]
    console.print(f"delta: {report['bytes_ratio']:g}x fewer bytes, "
                  f"{report['node_seconds_ratio']:g}x less node time", markup=False)
    forensics = report["ways"][-1]
    console.print(f"forensics before the resync: {forensics['forensics_bytes']:,} B fetched "
                  f"from the two nodes in {forensics['forensics_seconds']:.3f} s", markup=False,
                  highlight=False)
    confirm = report["confirmation"]
    console.print(f"confirmation of {confirm['particles']:,} particles ({confirm['bytes']:,} B): "
                  f"GPU read {confirm['gpu_read_ms']} ms, SHA-256 {confirm['sha256_ms']} ms "
                  f"({confirm['sha256_mb_per_s']:,} MB/s; BLAKE2b {confirm['blake2b_ms']} ms), "
                  f"a confirmer's whole answer {confirm['confirmer_answer_ms']} ms",
                  markup=False, highlight=False, soft_wrap=True)
    console.print(f"history ring: {ring['bytes_per_frame']:,} B of fold-1 items per frame "
                  f"({ring['ring_bytes']:,} B for {ring['ring_frames']} frames), GPU copy "
                  f"{ring['ring_copy_ms']} ms per frame against {ring['checksum_ms']} ms for "
                  f"the checksum (medians of {ring['frames']})", markup=False,
                  highlight=False, soft_wrap=True)
