"""Command-line edges of the cluster processes: flags in, typed configs out.

`cavesim master`, `cavesim node`, `cavesim run`, `cavesim replay` and `cavesim check`
register here; cavesim/cli.py owns the parser and the error handling.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from cavesim.cli import UsageError, frame_count, number_in, output_directory, scene_file
from cavesim.limits import GPU_RANGE
from cavesim.wire.keys import check_name
from cavesim.wire.messages import MAX_CHUNK_PARTICLES
from cavesim.wire.network import add_network_arguments, network_from_arguments, read_key
from cavesim.wire.snapshot import CHUNK_PARTICLES
from nodes.faults import parse_fault

DEFAULT_SCENE = "config/scenes/brownout.toml"  # the demo
CHECK_SCENE = "config/scenes/dust_devil.toml"  # busy from the first frame: faults show at once
DEFAULT_CAVE = "config/cave/flex4.toml"
CAVE_WALL_NAMES = ("front", "left", "right", "floor", "ceiling", "back")


def wall_names(count: int) -> tuple[str, ...]:
    """Names of `count` walls: the CAVE's own names first, then wall7, wall8, ..."""
    return tuple(CAVE_WALL_NAMES[i] if i < len(CAVE_WALL_NAMES) else f"wall{i + 1}"
                 for i in range(count))


def wall_list(text: str) -> tuple[str, ...]:
    try:
        walls = tuple(check_name("wall", name) for name in text.split(","))
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected comma-separated wall names: {e}") from e
    if len(set(walls)) != len(walls):
        raise argparse.ArgumentTypeError(f"wall names must be unique, got {text!r}")
    return walls


wall_count = number_in(int, 1, 64, "a number of walls")
seconds = number_in(float, 1e-3, 3600.0, "seconds")


def fault(text: str):
    try:
        return parse_fault(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def _configure_logging(verbose: bool) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, stream=sys.stderr,
                        format="%(asctime)s %(name)s %(levelname)s %(message)s")


def _network(args: argparse.Namespace, command: str):
    try:
        return network_from_arguments(args), read_key(args.key_file)
    except ValueError as e:
        raise UsageError(f"cavesim {command}: error: {e}") from e


def add_master(commands) -> None:
    parser = commands.add_parser("master", help="the clock, the barrier and divergence handling")
    parser.add_argument("--walls", type=wall_list, required=True, help="e.g. front,left,floor")
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE)
    parser.add_argument("--frames", type=frame_count, default=600)
    parser.add_argument("--barrier-timeout", type=seconds, default=2.0)
    parser.add_argument("--join-timeout", type=seconds, default=60.0)
    parser.add_argument("--on-loss", choices=("continue", "pause"), default="continue")
    parser.add_argument("--check-every", type=frame_count, default=1,
                        help="compare checksums every K frames (default: every frame)")
    parser.add_argument("--clock-seed", type=int, default=0)
    parser.add_argument("--dt", type=number_in(float, 1e-4, 0.1, "seconds"), default=1 / 60,
                        help="the fixed time step (default 1/60 s)")
    parser.add_argument("--realtime", action="store_true",
                        help="pace frames by the wall clock (accumulator, fixed dt)")
    parser.add_argument("--max-frame-time", type=number_in(float, 1e-3, 10.0, "seconds"),
                        default=0.1, help="real time: most wall time one tick may count")
    parser.add_argument("--max-substeps", type=number_in(int, 1, 100, "frames"), default=4,
                        help="real time: most frames sent back to back to catch up")
    parser.add_argument("--report", type=Path, help="write the run's JSON report here")
    parser.add_argument("--frame-log", type=Path, help="record every frame's inputs here")
    parser.add_argument("--progress", action="store_true", help="JSON progress lines on stdout")
    parser.add_argument("--verbose", action="store_true")
    add_network_arguments(parser)
    parser.set_defaults(handler=master)


def master(args: argparse.Namespace, console) -> int:
    from nodes.master import MasterConfig
    from nodes.master import main as run_master

    _configure_logging(args.verbose)
    network, key = _network(args, "master")
    config = MasterConfig(args.walls, args.scene, args.frames, args.session, network, key,
                          barrier_timeout=args.barrier_timeout, join_timeout=args.join_timeout,
                          on_loss=args.on_loss, check_every=args.check_every,
                          clock_seed=args.clock_seed, frame_log=args.frame_log, dt=args.dt,
                          realtime=args.realtime, max_frame_time=args.max_frame_time,
                          max_substeps=args.max_substeps)

    def progress(k: int, live: int) -> None:
        if args.progress:
            print(json.dumps({"frame": k, "frames": args.frames, "live": live}), flush=True)

    record = run_master(config, progress)
    summary = record.summary()
    if args.report:
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(json.dumps(summary, indent=2) + "\n")
    return 130 if record.interrupted else 0


def add_node(commands) -> None:
    parser = commands.add_parser("node", help="one wall: a GL context stepping in lock-step")
    parser.add_argument("--wall", type=lambda t: wall_list(t)[0], required=True)
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE)
    parser.add_argument("--inject", type=fault, action="append", default=[],
                        help="fault to inject into this node, KIND@FRAME (testing)")
    parser.add_argument("--slow-delay", type=seconds, default=1.5)
    parser.add_argument("--cave", type=scene_file, help="CAVE geometry (.toml) to draw the wall of")
    parser.add_argument("--render-every", type=number_in(int, 0, 10**9, "frames"), default=0,
                        help="draw the wall every K frames (0: never)")
    parser.add_argument("--images", type=Path, help="folder for <wall>/frame_<k>.png")
    parser.add_argument("--stereo", action="store_true", help="draw a left and a right eye")
    parser.add_argument("--gpu", type=number_in(int, *GPU_RANGE, "an EGL device index"),
                        help="EGL device to compute on (default: device 0; `cavesim doctor` "
                             "lists them)")
    parser.add_argument("--snapshot-chunk", type=number_in(int, 1, MAX_CHUNK_PARTICLES,
                                                           "particles"),
                        default=CHUNK_PARTICLES,
                        help=f"particles per reply of a snapshot this node sends "
                             f"(default: {CHUNK_PARTICLES}, 4 MiB)")
    parser.add_argument("--verbose", action="store_true")
    add_network_arguments(parser)
    parser.set_defaults(handler=node)


def node(args: argparse.Namespace, console) -> int:
    from nodes.node import NodeConfig
    from nodes.node import main as run_node

    _configure_logging(args.verbose)
    network, key = _network(args, "node")
    if args.render_every and (args.cave is None or args.images is None):
        raise UsageError("cavesim node: error: argument --render-every: drawing needs --cave "
                         "and --images too")
    config = NodeConfig(args.wall, args.scene, args.session, network, key,
                        tuple(args.inject), args.slow_delay, args.cave, args.render_every,
                        args.images, args.stereo, args.snapshot_chunk, gpu=args.gpu)
    return run_node(config)


def default_frames(scene, dt: float = 1 / 60) -> int:
    """Frames to play a scene's wand timeline to its end (600 without a timeline)."""
    helicopter = scene.helicopter
    if helicopter is None or not helicopter.timeline:
        return 600
    return round(helicopter.timeline[-1].t / dt)


def add_run(commands) -> None:
    parser = commands.add_parser("run", help="master + one node per wall on this machine")
    walls = parser.add_mutually_exclusive_group()
    walls.add_argument("--cave", type=scene_file, default=DEFAULT_CAVE,
                       help=f"CAVE geometry whose walls are drawn (default: {DEFAULT_CAVE})")
    walls.add_argument("--walls", type=wall_count, help="N undrawn walls instead of a CAVE")
    parser.add_argument("--render-every", type=number_in(int, 0, 10**9, "frames"), default=10,
                        help="each wall writes its picture every K frames (default 10; 0: never)")
    parser.add_argument("--stereo", action="store_true")
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE)
    parser.add_argument("--frames", type=frame_count,
                        help="default: the scene's wand timeline to its end, else 600")
    parser.add_argument("--out", type=Path, default=Path("out"))
    parser.add_argument("--session", default="run")
    parser.add_argument("--key-file", type=Path)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace, console) -> int:
    from nodes.run import RunPlan, run_walls

    try:
        check_name("session", args.session)
        read_key(args.key_file)
    except ValueError as e:
        raise UsageError(f"cavesim run: error: {e}") from e
    scene, cave = _checked_files(args)  # before anything is started
    walls = wall_names(args.walls) if args.walls else cave.names
    gpus = _gpus(args, walls, cave)
    output_directory(args.out, "run")
    frames = args.frames or default_frames(scene)
    plan = RunPlan(walls, args.scene, frames, args.out, args.session, args.key_file,
                   cave=None if args.walls else args.cave, render_every=args.render_every,
                   stereo=args.stereo, gpus=gpus)
    report = run_walls(plan, console)
    return 130 if report["interrupted"] else 0


def _checked_files(args: argparse.Namespace):
    """The run's scene and CAVE (None with --walls), checked before any process starts."""
    from cavesim.cave.geometry import load_cave
    from cavesim.errors import CaveError, SceneError
    from cavesim.scene import load_scene

    try:
        scene = load_scene(args.scene)
    except SceneError as e:
        raise UsageError(f"cavesim run: error: argument --scene: {e}") from e
    if args.walls:
        return scene, None
    try:
        return scene, load_cave(args.cave)
    except CaveError as e:
        raise UsageError(f"cavesim run: error: argument --cave: {e}") from e


def _gpus(args: argparse.Namespace, walls: tuple[str, ...], cave) -> dict[str, int]:
    """Each wall's EGL device: the CAVE file's `gpu`, else spread over this machine's GPUs."""
    from cavesim.errors import ContextError
    from cavesim.gl.devices import list_devices
    from nodes.gpus import spread_walls

    pinned = {} if cave is None else {w.name: w.gpu for w in cave.walls if w.gpu is not None}
    devices = list_devices()  # no EGL at all: its error says what to install
    try:
        return spread_walls(walls, pinned, devices)
    except ContextError as e:
        raise UsageError(f"cavesim run: error: argument --cave: {args.cave}: {e}") from e


def add_replay(commands) -> None:
    parser = commands.add_parser("replay", help="re-run a frame log; every checksum must match")
    parser.add_argument("log", type=Path, help="frames.log written by the master")
    parser.add_argument("--scene", type=scene_file, help="override the scene named in the log")
    parser.add_argument("--out", type=Path, help="write replay.json here (a directory)")
    parser.set_defaults(handler=replay)


def replay(args: argparse.Namespace, console) -> int:
    from rich.progress import Progress

    from cavesim.replay import replay as replay_log

    if not args.log.is_file():
        raise UsageError(f"cavesim replay: error: argument log: no file {str(args.log)!r}")
    if args.out:
        output_directory(args.out, "replay")
    try:
        with Progress(console=console) as progress:
            task = progress.add_task("replaying", total=None)
            result = replay_log(args.log, args.scene,
                                progress=lambda k: progress.update(task, completed=k))
    except ValueError as e:
        raise UsageError(f"cavesim replay: error: argument log: {e}") from e
    summary = result.summary()
    if args.out:
        (args.out / "replay.json").write_text(json.dumps(summary, indent=2) + "\n")
    verdict = "[green]every checksum reproduced" if result.equal else \
        f"[red]{len(result.mismatches)} frame(s) differ, first at {result.mismatches[0]['frame']}"
    console.print(f"{result.frames} frames replayed: {verdict}")
    return 0 if result.equal else 1


def add_check(commands) -> None:
    parser = commands.add_parser("check", help="consistency harness: inject faults, prove "
                                               "each is detected and healed")
    parser.add_argument("--walls", type=wall_count, default=3)
    parser.add_argument("--scene", type=scene_file, default=CHECK_SCENE)
    parser.add_argument("--frames", type=frame_count, default=300)
    parser.add_argument("--inject", type=fault, action="append", default=[],
                        metavar="KIND@FRAME[:NODE]",
                        help="bitflip, seed, drop, stale, kill, slow or rogue (repeatable)")
    parser.add_argument("--barrier-timeout", type=seconds, default=0.5)
    parser.add_argument("--on-loss", choices=("continue", "pause"), default="continue")
    parser.add_argument("--check-every", type=frame_count, default=1)
    parser.add_argument("--out", type=Path, default=Path("out/check"))
    parser.add_argument("--session", default="check")
    parser.set_defaults(handler=check)


def check(args: argparse.Namespace, console) -> int:
    from rich.progress import Progress

    from nodes.check import CheckPlan, run_check
    from nodes.check_report import check_table

    walls = wall_names(args.walls)
    for f in args.inject:
        if f.node is not None and f.node not in walls:
            raise UsageError(f"cavesim check: error: argument --inject: node {f.node!r} of "
                             f"{f} is not one of the walls {', '.join(walls)}")
        if f.frame > args.frames:
            raise UsageError(f"cavesim check: error: argument --inject: {f} is after the "
                             f"last frame {args.frames}")
    output_directory(args.out, "check")
    _configure_logging(False)
    plan = CheckPlan(walls, args.scene, args.frames, tuple(args.inject), args.out,
                     args.session, args.barrier_timeout, on_loss=args.on_loss,
                     check_every=args.check_every)
    with Progress(console=console) as progress:
        task = progress.add_task(f"check, {len(walls)} walls", total=args.frames)
        report = run_check(plan, lambda k, live: progress.update(task, completed=k))
    (args.out / "check.json").write_text(json.dumps(report, indent=2) + "\n")
    console.print(check_table(report))
    console.print(f"wrote {args.out / 'check.json'}")
    healthy = report["final"].get("agree") and report["all_detected"] and report["all_healed"]
    return 0 if healthy and (args.inject or report["divergences"] == 0) else 1
