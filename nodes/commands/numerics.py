"""`cavesim accuracy` (error against run time and field evaluations) and `cavesim stability`
(stiff and extreme cases): the numerics reports."""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console

from cavesim.core.errors import SceneError
from cavesim.core.limits import MAX_PARTICLES
from nodes.arguments import (
    RUN_ERROR,
    UsageError,
    frame_count,
    number_in,
    output_directory,
    output_folder,
    scene_file,
)


def add_accuracy(commands) -> None:
    from cavesim.tools.numerics.cases import HELICOPTER_SCENE, PARTICLES, QUICK_PARTICLES

    parser = commands.add_parser(
        "accuracy", help="error against run time and field evaluations of every integrator: "
                         "GPU, float64 twin and reference (checked by Dormand-Prince) in "
                         "uniform and turning flows, a vortex on three grids, a rotor "
                         "downwash, and sand in the last two")
    parser.add_argument("--scene", type=scene_file,
                        help=f"helicopter scene whose rotor downwash is the third case "
                             f"(default: {HELICOPTER_SCENE})")
    parser.add_argument("--out", type=output_folder, default=Path("out/accuracy"),
                        help="directory for accuracy.csv, accuracy.md, accuracy.json, "
                             "work_precision.png and work_precision_evaluations.png (default: "
                             "out/accuracy)")
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
    output_directory(args.out, "accuracy")
    run_command(scene, args.out, console, args.particles, args.quick)
    return 0


def add_stability(commands) -> None:
    parser = commands.add_parser(
        "stability", help="stiff sweep of every integrator and the extreme inputs")
    parser.add_argument("--frames", type=frame_count, default=120,
                        help="frames per stiff run (default 120)")
    parser.add_argument("--out", type=output_folder, default=Path("out/stability"),
                        help="directory for stability.json, .md and .png")
    parser.set_defaults(handler=stability)


def stability(args: argparse.Namespace, console: Console) -> int:
    """`cavesim stability`: exit 1 if an outcome disagrees with theory or a NaN got through."""
    from cavesim.gpu.gl.context import create_context
    from cavesim.tools.stability.report import run_stability

    output_directory(args.out, "stability")
    report = run_stability(create_context(), args.out, args.frames)
    console.print((args.out / "stability.md").read_text(), markup=False, highlight=False)
    console.print(f"wrote {args.out / 'stability.json'}, stability.md and stability.png")
    return 0 if report["sweep_agrees_with_theory"] and report["nan_free"] else RUN_ERROR
