"""`cavesim bench`: engine throughput, with --cluster the cost of the lock-step, with
--resync what healing a bitflip costs (full snapshot against delta), with --soak the
memory of a long cluster run, or with --render what drawing one wall for one eye costs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.errors import SceneError
from cavesim.core.limits import MAX_PARTICLES, WALL_RESOLUTION_RANGE
from nodes.arguments import (
    INTERRUPTED,
    MAX_WALLS,
    UsageError,
    cave_file,
    count_list,
    frame_count,
    number_in,
    scene_file,
    wall_count,
)
from nodes.run_folder import add_arguments as add_out_arguments
from nodes.run_folder import own_folder

BENCH_SCENE = "config/scenes/bench.toml"
BENCH_FRAMES = 10
QUICK_FRAMES = 3  # `bench --quick`
CLUSTER_NODES = "2,4,8"  # `bench --cluster`: node counts of the barrier runs
CLUSTER_FRAMES = 300
SOAK_ONLY = ("walls", "sample_every")  # flags of --soak alone
RENDER_ONLY = ("resolutions", "at_frame")  # flags of --render alone
ENGINE_ONLY = ("quick", "numpy_up_to")  # flags of the engine bench alone
# Parsing stops at the engine's addressing bound; the GL context's own limits are checked
# before measuring (a CapacityError, exit 1: the same flags may fit another driver).
particle_counts = count_list(MAX_PARTICLES, "particle counts")
node_counts = count_list(MAX_WALLS, "node counts")
particle_cap = number_in(int, 0, MAX_PARTICLES, "a particle count")
pixels = number_in(int, *WALL_RESOLUTION_RANGE, "pixels")


def resolution_list(text: str) -> list[tuple[int, int]]:
    """An argparse type: comma-separated WIDTHxHEIGHT wall resolutions."""
    try:
        return [(pixels(w), pixels(h)) for w, h in (part.split("x") for part in text.split(","))]
    except (ValueError, argparse.ArgumentTypeError) as e:
        low, high = WALL_RESOLUTION_RANGE
        raise argparse.ArgumentTypeError(
            f"expected comma-separated WIDTHxHEIGHT, each {low}..{high} pixels, got "
            f"{text!r}") from e


def add(commands) -> None:
    parser = commands.add_parser(
        "bench", help="throughput of both engine paths (GS/TF, compute) against the copy "
                      "bound and numpy")
    parser.add_argument("--scene", type=scene_file,
                        help=f"scene file (default: {BENCH_SCENE}; with --cluster: the "
                             f"lock-step run's scene, default config/scenes/dust_devil.toml; "
                             f"with --soak: default config/scenes/minimal.toml)")
    parser.add_argument("--sizes", type=particle_counts,
                        help="comma-separated particle counts (default: 1000000, 10000000 and "
                             "the largest the GL context allows, leaving out what it cannot "
                             "hold)")
    parser.add_argument("--quick", action="store_true",
                        help=f"a one-minute answer on any GL (llvmpipe on 2 cores included): "
                             f"100000 and 1000000 particles (each capped at the largest the "
                             f"context allows), {QUICK_FRAMES} timed frames per path; not with "
                             f"--sizes, --cluster, --resync or --soak")
    parser.add_argument("--numpy-up-to", type=particle_cap, metavar="N",
                        help="time the numpy twin only at sizes up to N particles (default: "
                             "1000000; 0: never); above, its cells read 'not timed'")
    parser.add_argument("--frames", type=frame_count,
                        help=f"timed frames per path after 2 warm-up frames, fewer (at least "
                             f"3) once a path's took 2 s (default: {BENCH_FRAMES}, with "
                             f"--quick {QUICK_FRAMES}); with --cluster: frames per run "
                             f"(default: {CLUSTER_FRAMES}); with --soak: frames of the run "
                             f"(default: 100000)")
    add_out_arguments(parser, "bench", "bench.json and bench.md, cluster.json and "
                      "cluster.md, resync.json, soak.json, or bench-render.json and "
                      "bench-render.md")
    parser.add_argument("--cluster", action="store_true",
                        help="lock-step figures instead: barrier round trip with 2, 4 and 8 "
                             "nodes, and a 4-wall run against four systems back to back")
    parser.add_argument("--nodes", type=node_counts,
                        help=f"with --cluster: node counts of the barrier runs "
                             f"(default: {CLUSTER_NODES})")
    parser.add_argument("--resync", action="store_true",
                        help="what healing a one-particle bitflip costs instead: the full "
                             "snapshot against the delta resync, two nodes on loopback, at "
                             "the one --sizes count (default 1000000); and the forensics' "
                             "history ring per frame")
    parser.add_argument("--soak", action="store_true",
                        help="a long cluster run as fast as it goes instead, sampling the "
                             "resident memory of the master and every node")
    parser.add_argument("--walls", type=wall_count,
                        help="with --soak: wall nodes of the run (default: 4)")
    parser.add_argument("--sample-every", type=frame_count,
                        help="with --soak: frames between memory samples (default: 10000, "
                             "or --frames if fewer)")
    parser.add_argument("--render", action="store_true",
                        help="what drawing one wall for one eye costs instead (draw, then "
                             "wait for the GPU): p50 and p90 per wall resolution, of the "
                             "scene's state at a built-up frame (default scene "
                             "config/scenes/brownout.toml), or with --sizes of full pools of "
                             "its particles; --frames: timed draws (default 20)")
    parser.add_argument("--resolutions", type=resolution_list,
                        help="with --render: comma-separated WIDTHxHEIGHT of the walls "
                             "drawn (default: 480x480,1920x1200)")
    parser.add_argument("--at-frame", type=frame_count,
                        help="with --render, without --sizes: the frame whose state is drawn "
                             "(default: 720, the demo's cloud built up)")
    parser.set_defaults(handler=bench)


def _bench_scene(path: Path):
    from cavesim.core.scene import load_scene

    try:
        return load_scene(path)
    except SceneError as e:
        raise UsageError(f"cavesim bench: error: argument --scene: {e}") from e


def bench(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench`: check the scene and the output directory, then `run_bench`
    (or, with --cluster, `bench_cluster`; with --resync, `bench_resync`; with --soak,
    `bench_soak`)."""
    other = next((f"--{mode}" for mode in ("soak", "resync", "cluster", "render")
                  if getattr(args, mode)), None)
    if other is not None:
        _only_with_engine_bench(args, other)
    if args.render:
        return bench_render(args, console)
    _only_with_flag(args, RENDER_ONLY, "--render")
    if args.soak:
        return bench_soak(args, console)
    _only_with_soak(args)
    if args.resync:
        return bench_resync(args, console)
    if args.cluster:
        return bench_cluster(args, console)
    if args.nodes is not None:
        raise UsageError("cavesim bench: error: argument --nodes: only with --cluster")
    if args.quick and args.sizes is not None:
        raise UsageError("cavesim bench: error: argument --quick: not with --sizes (it "
                         "measures its own)")
    # GL loads only for the commands that use it
    from cavesim.tools.bench import run_bench
    from cavesim.tools.bench.measure import NUMPY_UP_TO, BenchPlan
    from cavesim.tools.bench.report import Ended

    scene = _bench_scene(args.scene or scene_file(BENCH_SCENE))
    plan = BenchPlan(args.frames or (QUICK_FRAMES if args.quick else BENCH_FRAMES),
                     NUMPY_UP_TO if args.numpy_up_to is None else args.numpy_up_to)
    with own_folder(args.out, "bench", args.force) as folder:
        report = run_bench(scene, args.sizes, plan, folder.path, console, quick=args.quick)
    if report["ended"] == Ended.INTERRUPTED:
        finished = len(report["sizes"])
        print(f"cavesim bench: interrupted; {finished} finished size"
              f"{'' if finished == 1 else 's'} in {folder.path / 'bench.json'}",
              file=sys.stderr)
        return INTERRUPTED
    return 0


def bench_cluster(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench --cluster`: check the flags, then `run_cluster_bench`."""
    from nodes.cluster_bench.barrier import BARRIER_SCENE, LOCKSTEP_SCENE, run_cluster_bench

    if args.sizes is not None:
        raise UsageError("cavesim bench: error: argument --sizes: not with --cluster "
                         "(the barrier runs use --nodes)")
    lockstep_scene = args.scene or scene_file(LOCKSTEP_SCENE)
    _bench_scene(lockstep_scene)
    with own_folder(args.out, "bench", args.force) as folder:
        run_cluster_bench(scene_file(BARRIER_SCENE), lockstep_scene, cave_file(DEFAULT_CAVE),
                          args.nodes or node_counts(CLUSTER_NODES),
                          args.frames or CLUSTER_FRAMES, folder.path, console)
    return 0


def bench_resync(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench --resync`: check the flags, then `run_resync_bench`."""
    from nodes.cluster_bench.resync import RESYNC_PARTICLES, run_resync_bench

    for name, value in (("--cluster", args.cluster), ("--nodes", args.nodes is not None),
                        ("--scene", args.scene is not None),
                        ("--frames", args.frames is not None)):
        if value:
            raise UsageError(f"cavesim bench: error: argument {name}: not with --resync")
    sizes = args.sizes or [RESYNC_PARTICLES]
    if len(sizes) != 1:
        raise UsageError(f"cavesim bench: error: argument --sizes: --resync measures one "
                         f"particle count, got {len(sizes)}")
    with own_folder(args.out, "bench", args.force) as folder:
        run_resync_bench(sizes[0], folder.path, console)
    return 0


def _only_with_engine_bench(args: argparse.Namespace, mode: str) -> None:
    for name in ENGINE_ONLY:
        if getattr(args, name) not in (None, False):
            flag = "--" + name.replace("_", "-")
            raise UsageError(f"cavesim bench: error: argument {flag}: not with {mode}")


def _only_with_soak(args: argparse.Namespace) -> None:
    _only_with_flag(args, SOAK_ONLY, "--soak")


def _only_with_flag(args: argparse.Namespace, names: tuple[str, ...], mode: str) -> None:
    for name in names:
        if getattr(args, name) is not None:
            flag = "--" + name.replace("_", "-")
            raise UsageError(f"cavesim bench: error: argument {flag}: only with {mode}")


def bench_render(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench --render`: check the flags, then `run_render_bench`."""
    from cavesim.core.cave.geometry import load_cave
    from cavesim.tools.bench.render_cost import (
        BUILT_UP_FRAME,
        RENDER_DRAWS,
        RENDER_SCENE,
        RESOLUTIONS,
    )
    from cavesim.tools.bench.render_report import run_render_bench
    from cavesim.tools.bench.report import Ended

    for name, value in (("--cluster", args.cluster), ("--resync", args.resync),
                        ("--soak", args.soak), ("--nodes", args.nodes is not None)):
        if value:
            raise UsageError(f"cavesim bench: error: argument {name}: not with --render")
    _only_with_soak(args)
    if args.sizes is not None and args.at_frame is not None:
        raise UsageError("cavesim bench: error: argument --at-frame: not with --sizes (a "
                         "pool is drawn as loaded)")
    scene = _bench_scene(args.scene or scene_file(RENDER_SCENE))
    front = load_cave(cave_file(DEFAULT_CAVE)).wall("front")
    with own_folder(args.out, "bench", args.force) as folder:
        report = run_render_bench(scene, front, args.resolutions or list(RESOLUTIONS),
                                  args.sizes,
                                  args.at_frame or BUILT_UP_FRAME,
                                  args.frames or RENDER_DRAWS, folder.path, console)
    if report["ended"] == Ended.INTERRUPTED:
        print(f"cavesim bench: interrupted; {len(report['measurements'])} measurements in "
              f"{folder.path / 'bench-render.json'}", file=sys.stderr)
        return INTERRUPTED
    return 0


def bench_soak(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench --soak`: check the flags, then `run_soak`."""
    from nodes.cluster_bench.soak import (
        SOAK_EVERY,
        SOAK_FRAMES,
        SOAK_SCENE,
        SOAK_WALLS,
        run_soak,
    )

    for name, value in (("--cluster", args.cluster), ("--nodes", args.nodes is not None),
                        ("--sizes", args.sizes is not None), ("--resync", args.resync)):
        if value:
            raise UsageError(f"cavesim bench: error: argument {name}: not with --soak")
    frames = args.frames or SOAK_FRAMES
    every = args.sample_every or min(SOAK_EVERY, frames)
    if every > frames:
        raise UsageError(f"cavesim bench: error: argument --sample-every: expected at most "
                         f"the run's {frames} frames, got {every}")
    scene = args.scene or scene_file(SOAK_SCENE)
    _bench_scene(scene)
    with own_folder(args.out, "bench", args.force) as folder:
        run_soak(scene, args.walls or SOAK_WALLS, frames, every, folder.path, console)
    return 0
