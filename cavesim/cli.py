"""The `cavesim` command line: argument parsing only; each subcommand calls a typed function.

Every subcommand is one `add_<name>` function registering its parser and its handler.
Bad input ends with a one-line error naming the flag, its value and what is allowed
(exit code 2); an error while running exits with 1; neither prints a traceback. A bug
ends with one line too; its traceback goes only to a log (stderr not a terminal) or where
CAVESIM_TRACEBACK is set.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from rich.console import Console

from cavesim.errors import CavesimError, SceneError
from cavesim.limits import MAX_PARTICLES

REPO_ROOT = Path(__file__).resolve().parents[1]
BENCH_SCENE = "config/scenes/bench.toml"
BENCH_SIZES = "100000,300000,1000000"
BENCH_FRAMES = 10
CLUSTER_NODES = "2,4,8"  # `bench --cluster`: node counts of the barrier runs
CLUSTER_FRAMES = 300
MAX_NODES = 64
USAGE_ERROR, RUN_ERROR = 2, 1
TRACEBACK_VARIABLE = "CAVESIM_TRACEBACK"
PIPED_WIDTH = 120  # columns of output that is not a terminal


class UsageError(Exception):
    """Bad command-line input; the message is the whole line to print."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse would print the usage and exit
        raise UsageError(f"{self.prog}: error: {message}")


def number_in(parse: type, low: float, high: float, what: str):
    """An argparse type: one number parsed by `parse` in [low, high], named `what`."""

    def check(text: str):
        try:
            value = parse(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected {what} in [{low}, {high}], got {text!r}")
        return value

    return check


def count_list(high: int, what: str):
    """An argparse type: comma-separated whole numbers, each in 1..high."""
    one = number_in(int, 1, high, what)

    def check(text: str) -> list[int]:
        try:
            return [one(part) for part in text.split(",")]
        except argparse.ArgumentTypeError as e:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated {what}, each 1..{high}, got {text!r}") from e

    return check


# Parsing stops at the engine's addressing bound; the GL context's own limits are checked
# before measuring (a CapacityError, exit 1: the same flags may fit another driver).
particle_counts = count_list(MAX_PARTICLES, "particle counts")
node_counts = count_list(MAX_NODES, "node counts")
frame_count = number_in(int, 1, 10**9, "a whole number of frames")


def scene_file(text: str) -> Path:
    """An existing scene file: relative to the current directory, else to the repository."""
    path = Path(text)
    for candidate in (path, REPO_ROOT / path):
        if candidate.is_file():
            return candidate
    raise argparse.ArgumentTypeError(
        f"no scene file {text!r} in the current directory or in {REPO_ROOT}; "
        f"give the path of a scene .toml file")


def add_bench(commands) -> None:
    parser = commands.add_parser(
        "bench", help="throughput of the GS/TF step against numpy and a compute-shader bound")
    parser.add_argument("--scene", type=scene_file,
                        help=f"scene file (default: {BENCH_SCENE}; with --cluster: the "
                             f"lock-step run's scene, default config/scenes/dust_devil.toml)")
    parser.add_argument("--sizes", type=particle_counts,
                        help=f"comma-separated particle counts (default: {BENCH_SIZES})")
    parser.add_argument("--frames", type=frame_count,
                        help=f"timed frames per path after 2 warm-up frames (default: "
                             f"{BENCH_FRAMES}); with --cluster: frames per run "
                             f"(default: {CLUSTER_FRAMES})")
    parser.add_argument("--out", type=Path, default=Path("out/bench"),
                        help="directory for bench.json and bench.md, or cluster.json and "
                             "cluster.md (default: out/bench)")
    parser.add_argument("--cluster", action="store_true",
                        help="lock-step figures instead: barrier round trip with 2, 4 and 8 "
                             "nodes, and a 4-wall run against four systems back to back")
    parser.add_argument("--nodes", type=node_counts,
                        help=f"with --cluster: node counts of the barrier runs "
                             f"(default: {CLUSTER_NODES})")
    parser.set_defaults(handler=bench)


def output_directory(path: Path, command: str, flag: str = "--out") -> Path:
    """Make the output directory before any work, so a bad one costs no run."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UsageError(f"cavesim {command}: error: argument {flag}: cannot make directory "
                         f"{str(path)!r}: {e.strerror or e}; give a writable directory") from e
    return path


def _bench_scene(path: Path):
    from cavesim.scene import load_scene

    try:
        return load_scene(path)
    except SceneError as e:
        raise UsageError(f"cavesim bench: error: argument --scene: {e}") from e


def bench(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench`: check the scene and the output directory, then `run_bench`
    (or, with --cluster, `bench_cluster`)."""
    if args.cluster:
        return bench_cluster(args, console)
    if args.nodes is not None:
        raise UsageError("cavesim bench: error: argument --nodes: only with --cluster")
    from cavesim.bench import run_bench  # GL and numpy load only for the commands that use them

    scene = _bench_scene(args.scene or scene_file(BENCH_SCENE))
    output_directory(args.out, "bench")
    run_bench(scene, args.sizes or particle_counts(BENCH_SIZES), args.frames or BENCH_FRAMES,
              args.out, console)
    return 0


def bench_cluster(args: argparse.Namespace, console: Console) -> int:
    """`cavesim bench --cluster`: check the flags, then `run_cluster_bench`."""
    from cavesim.bench.cluster import BARRIER_SCENE, LOCKSTEP_SCENE, run_cluster_bench

    if args.sizes is not None:
        raise UsageError("cavesim bench: error: argument --sizes: not with --cluster "
                         "(the barrier runs use --nodes)")
    lockstep_scene = args.scene or scene_file(LOCKSTEP_SCENE)
    _bench_scene(lockstep_scene)
    output_directory(args.out, "bench")
    run_cluster_bench(scene_file(BARRIER_SCENE), lockstep_scene,
                      args.nodes or node_counts(CLUSTER_NODES), args.frames or CLUSTER_FRAMES,
                      args.out, console)
    return 0


def add_stability(commands) -> None:
    parser = commands.add_parser(
        "stability", help="stiff sweep of every integrator and the extreme inputs")
    parser.add_argument("--frames", type=frame_count, default=120,
                        help="frames per stiff run (default 120)")
    parser.add_argument("--out", type=Path, default=Path("out/stability"),
                        help="directory for stability.json, .md and .png")
    parser.set_defaults(handler=stability)


def stability(args: argparse.Namespace, console: Console) -> int:
    """`cavesim stability`: exit 1 if an outcome disagrees with theory or a NaN got through."""
    from cavesim.gl.context import create_context
    from cavesim.stability.report import run_stability

    report = run_stability(create_context(), args.out, args.frames)
    console.print((args.out / "stability.md").read_text(), markup=False, highlight=False)
    console.print(f"wrote {args.out / 'stability.json'}, stability.md and stability.png")
    return 0 if report["sweep_agrees_with_theory"] and report["nan_free"] else 1


def add_accuracy(commands) -> None:
    from cavesim.numerics.cases import HELICOPTER_SCENE, PARTICLES, QUICK_PARTICLES

    parser = commands.add_parser(
        "accuracy", help="error against run time of every integrator: GPU, float64 twin and "
                         "reference in a uniform flow, a vortex and a rotor downwash")
    parser.add_argument("--scene", type=scene_file,
                        help=f"helicopter scene whose rotor downwash is the third case "
                             f"(default: {HELICOPTER_SCENE})")
    parser.add_argument("--out", type=Path, default=Path("out/accuracy"),
                        help="directory for accuracy.csv, accuracy.md, accuracy.json and "
                             "work_precision.png (default: out/accuracy)")
    parser.add_argument("--particles", type=number_in(int, 1, MAX_PARTICLES,
                                                      "a particle count"),
                        help=f"particles per case (default: {PARTICLES:,}; with --quick: "
                             f"{QUICK_PARTICLES:,})")
    parser.add_argument("--quick", action="store_true",
                        help="fewer dts (1/15 to 1/240 s) and particles: a smoke run")
    parser.set_defaults(handler=accuracy)


def accuracy(args: argparse.Namespace, console: Console) -> int:
    """`cavesim accuracy`: check the scene and the output directory, then `run_command`."""
    from cavesim.numerics import run_command
    from cavesim.numerics.cases import HELICOPTER_SCENE, downwash_case

    scene = args.scene or scene_file(HELICOPTER_SCENE)
    try:
        downwash_case(scene, 1)
    except SceneError as e:
        raise UsageError(f"cavesim accuracy: error: argument --scene: {e}") from e
    output_directory(args.out, "accuracy")
    run_command(scene, args.out, console, args.particles, args.quick)
    return 0


def add_doctor(commands) -> None:
    from cavesim.wire.network import add_network_arguments

    parser = commands.add_parser(
        "doctor", help="what this node offers: EGL devices, GL limits, zenoh, windows; "
                       "exit 1 with the reason and the fix if it cannot run cavesim")
    parser.add_argument("--out", type=Path, default=Path("out/doctor.json"),
                        help="where to write the findings as JSON (default: out/doctor.json)")
    add_network_arguments(parser)
    parser.set_defaults(handler=doctor)


def doctor(args: argparse.Namespace, console: Console) -> int:
    """`cavesim doctor`: check the flags as a node would, then `run_doctor`."""
    from cavesim.doctor.report import run_doctor
    from cavesim.wire.keys import check_name
    from cavesim.wire.network import network_from_arguments, read_key

    try:
        check_name("session", args.session)
        read_key(args.key_file)
        network = network_from_arguments(args)
        network.zenoh_config()
    except ValueError as e:
        raise UsageError(f"cavesim doctor: error: {e}") from e
    output_directory(args.out.parent, "doctor")
    verdict = run_doctor(network, args.out, console)
    if verdict.ok:
        return 0
    print(f"cavesim doctor: this node cannot run cavesim: {verdict.reason}; fix: {verdict.fix}",
          file=sys.stderr)
    return RUN_ERROR


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cavesim", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="command")
    add_bench(commands)
    add_accuracy(commands)
    add_stability(commands)
    add_doctor(commands)
    from nodes import commands as cluster  # nodes/ builds on cavesim/, so imported late

    for add in (cluster.add_run, cluster.add_master, cluster.add_node, cluster.add_replay,
                cluster.add_check):
        add(commands)
    return parser


def _console() -> Console:
    console = Console()
    if not console.is_terminal:  # a log or a pipe: rich would squeeze wide tables into 80
        console.width = max(console.width, PIPED_WIDTH)
    return console


def main(argv: Sequence[str] | None = None) -> int:
    """Run one `cavesim` command; return its exit code."""
    try:
        args = build_parser().parse_args(argv)
        return args.handler(args, _console())
    except UsageError as e:
        print(e, file=sys.stderr)
        return USAGE_ERROR
    except CavesimError as e:
        print(f"cavesim: error: {e}", file=sys.stderr)
        return RUN_ERROR
    except Exception as e:  # a bug: one line for a person, the traceback for a log
        if os.environ.get(TRACEBACK_VARIABLE) or not sys.stderr.isatty():
            traceback.print_exc()
        print(f"cavesim: error: internal error, {type(e).__name__}: {e} (a bug; set "
              f"{TRACEBACK_VARIABLE}=1 for the traceback)", file=sys.stderr)
        return RUN_ERROR
