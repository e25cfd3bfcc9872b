"""`cavesim accuracy` (error against run time and field evaluations) and `cavesim stability`
(stiff and extreme cases): the numerics reports."""

from __future__ import annotations

import argparse

from rich.console import Console

from cavesim.core.errors import SceneError
from cavesim.core.limits import MAX_PARTICLES
from nodes.arguments import (
    RUN_ERROR,
    UsageError,
    frame_count,
    number_in,
    scene_file,
)
from nodes.run_folder import add_arguments as add_out_arguments
from nodes.run_folder import own_folder


def add_accuracy(commands) -> None:
    from cavesim.tools.numerics.cases import HELICOPTER_SCENE, PARTICLES, QUICK_PARTICLES

    parser = commands.add_parser(
        "accuracy", help="error against run time and field evaluations of every integrator: "
                         "GPU, float64 twin and reference (checked by Dormand-Prince) in "
                         "uniform and turning flows, a vortex on three grids, a rotor "
                         "downwash, sand in the last two, and passive tracers in a "
                         "solid-body vortex")
    parser.add_argument("--scene", type=scene_file,
                        help=f"helicopter scene whose rotor downwash is the third case "
                             f"(default: {HELICOPTER_SCENE})")
    add_out_arguments(parser, "accuracy", "accuracy.csv, accuracy.md, accuracy.json, "
                      "work_precision.png and work_precision_evaluations.png")
    parser.add_argument("--particles", type=number_in(int, 1, MAX_PARTICLES,
                                                      "a particle count"),
                        help=f"particles per case (default: {PARTICLES:,}; with --quick: "
                             f"{QUICK_PARTICLES:,})")
    parser.add_argument("--quick", action="store_true",
                        help="fewer dts (1/15 to 1/240 s) and particles: a smoke run")
    parser.set_defaults(handler=accuracy)


def accuracy(args: argparse.Namespace, console: Console) -> int:
    """`cavesim accuracy`: check the scene and the output directory, then `run_command`."""
    from cavesim.tools.numerics import run_command
    from cavesim.tools.numerics.cases import HELICOPTER_SCENE, downwash_case

    scene = args.scene or scene_file(HELICOPTER_SCENE)
    try:
        downwash_case(scene, 1)
    except SceneError as e:
        raise UsageError(f"cavesim accuracy: error: argument --scene: {e}") from e
    with own_folder(args.out, "accuracy", args.force) as folder:
        run_command(scene, folder.path, console, args.particles, args.quick)
    return 0


def add_stability(commands) -> None:
    parser = commands.add_parser(
        "stability", help="stiff sweep of every integrator and the extreme inputs")
    parser.add_argument("--frames", type=frame_count, default=120,
                        help="frames per stiff run (default 120)")
    add_out_arguments(parser, "stability", "stability.json, .md and .png")
    parser.set_defaults(handler=stability)


def stability(args: argparse.Namespace, console: Console) -> int:
    """`cavesim stability`: exit 1 if an outcome disagrees with theory or a NaN got through."""
    from cavesim.gpu.gl.context import create_context
    from cavesim.tools.stability.report import run_stability

    with own_folder(args.out, "stability", args.force) as folder:
        report = run_stability(create_context(), folder.path, args.frames)
    console.print((folder.path / "stability.md").read_text(), markup=False, highlight=False)
    console.print(f"wrote {folder.path / 'stability.json'}, stability.md and stability.png")
    return 0 if report["sweep_agrees_with_theory"] and report["nan_free"] else RUN_ERROR
