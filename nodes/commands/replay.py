"""`cavesim replay`: re-run a frame log on one context; every checksum must come back.

A torn tail (the master stopped mid-record) is told, and is no failure: the replay covers
every whole record before it. A corrupt record is a failure: the replay stops there.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.markup import escape
from rich.progress import Progress

from cavesim.core.framelog import TORN
from cavesim.core.output import writing
from nodes.arguments import (
    RUN_ERROR,
    UsageError,
    add_trajectory_arguments,
    frame_log_path,
    output_directory,
    output_folder,
    scene_file,
    trajectories_requested,
)


def add(commands) -> None:
    parser = commands.add_parser("replay", help="re-run a frame log; every checksum must match")
    parser.add_argument("log", type=Path,
                        help="frames.log written by the master, or the run's folder holding it")
    parser.add_argument("--scene", type=scene_file, help="override the scene named in the log")
    parser.add_argument("--out", type=output_folder,
                        help="write replay.json (and trajectories.parquet) here (a directory)")
    add_trajectory_arguments(parser)
    parser.set_defaults(handler=replay)


def replay(args: argparse.Namespace, console) -> int:
    from cavesim.tools.log_replay import replay as replay_log

    args.log = frame_log_path(args.log, "replay")
    tracks = trajectories_requested(args, "replay")
    if tracks is not None and not args.out:
        raise UsageError("cavesim replay: error: argument --trajectories: give --out DIR for "
                         "trajectories.parquet")
    if args.out:
        output_directory(args.out, "replay")
    try:
        with Progress(console=console) as progress:
            task = progress.add_task("replaying", total=None)
            result = replay_log(
                args.log, args.scene, progress=lambda k: progress.update(task, completed=k),
                trajectories=None if tracks is None else (args.out, *tracks))
    except ValueError as e:
        raise UsageError(f"cavesim replay: error: argument log: {e}") from e
    if args.out:
        with writing(args.out / "replay.json"):
            (args.out / "replay.json").write_text(json.dumps(result.summary(), indent=2) + "\n")
    for warning in result.warnings:
        console.print(f"[yellow]warning: {escape(warning)}")
    console.print(f"{result.frames} frames replayed: {verdict(result)}")
    if result.trajectories:
        console.print(f"wrote {escape(result.trajectories)}")
    damage = result.damage
    if damage is not None:
        colour = "yellow" if damage.kind == TORN else "red"
        console.print(f"[{colour}]{escape(str(args.log))}: {damage.describe()}")
    return 0 if result.equal and (damage is None or damage.kind == TORN) else RUN_ERROR


def verdict(result) -> str:
    if result.mismatches:
        return (f"[red]{len(result.mismatches)} frame(s) differ, first at "
                f"{result.mismatches[0]['frame']}")
    return "[green]every checksum reproduced" if result.equal else "[red]no whole record"
