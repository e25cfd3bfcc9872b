"""`cavesim render`: a run's pictures drawn again from its frame log, into a folder of its
own: the walls at the frames asked for, the unfolded-CAVE composites and, with --video,
the MP4 and the small GIF, as `cavesim run` draws them. Every frame re-run must give the
log's checksum; the render stops at the first that does not, and says so."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.errors import CaveError
from cavesim.core.framelog import TORN
from cavesim.core.limits import WALL_RESOLUTION_RANGE
from cavesim.core.output import check_written, writing
from nodes.arguments import (
    RUN_ERROR,
    UsageError,
    cave_file,
    frame_count,
    frame_log_path,
    frame_range,
    number_in,
    scene_file,
)
from nodes.commands.replay import verdict
from nodes.progress import rated_progress
from nodes.run_folder import add_arguments as add_out_arguments
from nodes.run_folder import own_folder

RENDER_EVERY = 10  # as `cavesim run --render-every`
MAX_SCALE = 4.0


def add(commands) -> None:
    parser = commands.add_parser("render", help="draw a run's pictures again from its frame "
                                                "log, checking every frame's checksum")
    parser.add_argument("log", type=Path,
                        help="frames.log written by the master, or the run's folder holding it")
    parser.add_argument("--cave", type=cave_file, default=DEFAULT_CAVE,
                        help=f"the CAVE whose walls are drawn; give the run's, the log does "
                             f"not name it (default: {DEFAULT_CAVE})")
    parser.add_argument("--frames", type=frame_range, metavar="A:B",
                        help="draw frames A to B only (A: or :B leave an end open; default: "
                             "the whole log); frames before A are re-run, not drawn")
    parser.add_argument("--every", type=frame_count, default=RENDER_EVERY, metavar="K",
                        help=f"draw the frames that are a multiple of K, as `cavesim run "
                             f"--render-every K` does (default {RENDER_EVERY}; 1: every frame)")
    parser.add_argument("--scale", type=number_in(float, 0.01, MAX_SCALE, "a scale"),
                        default=1.0,
                        help=f"each wall's picture at its resolution times this (default 1; "
                             f"a side stays within {WALL_RESOLUTION_RANGE[0]}.."
                             f"{WALL_RESOLUTION_RANGE[1]} px)")
    parser.add_argument("--stereo", action="store_true",
                        help="draw each wall for both eyes (the right eye's pictures beside "
                             "the left's; composites and video show the left)")
    parser.add_argument("--video", action="store_true",
                        help="also render.mp4 and a small render.gif at the run's own pace")
    parser.add_argument("--scene", type=scene_file,
                        help="override the scene named in the log (a warning says so)")
    add_out_arguments(parser, "render", "the wall pictures, composites, video and render.json")
    parser.set_defaults(handler=render)


def render(args: argparse.Namespace, console: Console) -> int:
    """`cavesim render`: check the log, the CAVE and the frames asked for, then re-run and
    draw into the render's own folder; exit 1 when a checksum differs."""
    from cavesim.core.cave.geometry import load_cave
    from cavesim.tools.log_render import RenderPlan, render_log
    from cavesim.tools.log_replay import LogReplay
    from cavesim.tools.reports.run_pictures import assemble_pictures

    log = frame_log_path(args.log, "render")
    if args.out is not None and log.resolve().is_relative_to(args.out.resolve()):
        raise UsageError(f"cavesim render: error: argument --out: {str(args.out)!r} holds the "
                         f"frame log it would draw ({log}); give another folder, or leave "
                         f"--out off for a fresh one under out/")
    try:
        cave = load_cave(args.cave).scaled(args.scale)
    except CaveError as e:
        raise UsageError(f"cavesim render: error: argument --cave: {e}") from e
    try:
        replay = LogReplay(log, args.scene)
    except ValueError as e:
        raise UsageError(f"cavesim render: error: argument log: {e}") from e
    with replay:
        first, last = _drawn_span(args, len(replay.frames))
        with own_folder(args.out, "render", args.force) as folder, \
                rated_progress(console) as progress:
            plan = RenderPlan(cave, folder.path / "walls", first, last, args.every,
                              args.stereo)
            task = progress.add_task("re-running the log", total=last, live="",
                                     unit="frames")
            rendered = render_log(replay, plan, lambda k: progress.update(task, completed=k))
            images = assemble_pictures(cave, folder.path, rendered.dt * args.every, progress,
                                       "render", args.video) if rendered.pictures else {}
            path = folder.path / "render.json"
            with writing(path):
                path.write_text(json.dumps({
                    **rendered.replay.summary(), "cave": str(args.cave), "frames_drawn":
                    [first, last], "every": args.every, "scale": args.scale,
                    "pictures": rendered.pictures, "images": images}, indent=2) + "\n")
            check_written(path)
    return _told(rendered.replay, log, path, console)


def _drawn_span(args: argparse.Namespace, frames: int) -> tuple[int, int]:
    """The first and last frame to draw, checked against the log's whole frames."""
    if frames == 0:
        raise UsageError(f"cavesim render: error: argument log: {str(args.log)!r} holds no "
                         f"whole frame")
    first, last = args.frames or (1, None)
    last = frames if last is None else last
    if last > frames:
        raise UsageError(f"cavesim render: error: argument --frames: the log holds frames "
                         f"1..{frames}, got {first}:{last}")
    if last // args.every * args.every < first:
        raise UsageError(f"cavesim render: error: argument --every: no frame in {first}:{last} "
                         f"is a multiple of {args.every}; give a smaller --every or more "
                         f"frames")
    return first, last


def _told(result, log: Path, report: Path, console: Console) -> int:
    """Say how the re-run went; the exit code."""
    for warning in result.warnings:
        console.print(f"[yellow]warning: {escape(warning)}")
    console.print(f"{result.frames} frames re-run: {verdict(result)}")
    if result.mismatches:
        console.print(f"[red]the render stopped at frame {result.mismatches[0]['frame']}, "
                      f"whose checksum differs from the log's: from there on the state is "
                      f"not the run's; the pictures drawn before it are")
    damage = result.damage
    if damage is not None:
        colour = "yellow" if damage.kind == TORN else "red"
        console.print(f"[{colour}]{escape(str(log))}: {damage.describe()}")
    console.print(f"wrote {report}")
    return 0 if result.equal and (damage is None or damage.kind == TORN) else RUN_ERROR
