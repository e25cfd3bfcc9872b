"""`cavesim replay`: re-run a frame log on one context; every checksum must come back."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.progress import Progress

from cavesim.tools.arguments import RUN_ERROR, UsageError, output_directory, scene_file


def add(commands) -> None:
    parser = commands.add_parser("replay", help="re-run a frame log; every checksum must match")
    parser.add_argument("log", type=Path, help="frames.log written by the master")
    parser.add_argument("--scene", type=scene_file, help="override the scene named in the log")
    parser.add_argument("--out", type=Path, help="write replay.json here (a directory)")
    parser.set_defaults(handler=replay)


def replay(args: argparse.Namespace, console) -> int:
    from cavesim.tools.replay import replay as replay_log

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
    if args.out:
        (args.out / "replay.json").write_text(json.dumps(result.summary(), indent=2) + "\n")
    verdict = "[green]every checksum reproduced" if result.equal else \
        f"[red]{len(result.mismatches)} frame(s) differ, first at {result.mismatches[0]['frame']}"
    console.print(f"{result.frames} frames replayed: {verdict}")
    return 0 if result.equal else RUN_ERROR
