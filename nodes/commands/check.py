"""`cavesim check`: the consistency harness; inject faults, prove each is detected and
healed."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rich.progress import Progress

from cavesim.core.output import check_written, writing
from nodes.arguments import (
    RUN_ERROR,
    UsageError,
    cave_file,
    configure_logging,
    fault_spec,
    frame_count,
    scene_file,
    seconds,
    session_name,
    wall_count,
    wall_names,
)
from nodes.budget_flags import add_arguments as add_budget_arguments
from nodes.budget_flags import limits_from
from nodes.faults import (
    CHECK_MAX_LAG,
    COLLISIONS,
    CONTROL_REQUESTS,
    KINDS,
    MIN_COLLISION_WALLS,
    divergence_frames,
    every_kind,
    last_action,
)
from nodes.lockstep import LOSS_POLICIES, RESYNC_MODES
from nodes.run_folder import add_arguments as add_out_arguments
from nodes.run_folder import own_folder

CHECK_SCENE = "config/scenes/dust_devil.toml"  # busy from the first frame: faults show at once


def add(commands) -> None:
    parser = commands.add_parser("check", help="consistency harness: inject faults, prove "
                                               "each is detected and healed")
    members = parser.add_mutually_exclusive_group()
    members.add_argument("--walls", type=wall_count, default=3,
                         help="N walls, one node each (default 3)")
    members.add_argument("--cave", type=cave_file,
                         help="the nodes of this CAVE file instead: a node of several walls "
                              "(`node = ...`) steps once for them all")
    parser.add_argument("--scene", type=scene_file, default=CHECK_SCENE)
    parser.add_argument("--frames", type=frame_count, default=300)
    parser.add_argument("--inject", type=fault_spec, action="append", default=[],
                        metavar="KIND@FRAME[:NODE]",
                        help=f"{', '.join(KINDS)} (repeatable)")
    parser.add_argument("--every-kind", action="store_true",
                        help="also inject a fault of every kind, spread evenly over --frames "
                             "(the master-kill last)")
    parser.add_argument("--barrier-timeout", type=seconds, default=0.5)
    add_budget_arguments(parser, max_lag=CHECK_MAX_LAG)
    parser.add_argument("--on-loss", choices=LOSS_POLICIES, default="continue")
    parser.add_argument("--check-every", type=frame_count, default=1)
    parser.add_argument("--resync", choices=RESYNC_MODES, default="delta",
                        help="how a diverged node loads the healthy state: a delta of the "
                             "differing blocks first (default), or the full snapshot")
    add_out_arguments(parser, "check", "check.json, the frame log and the nodes' logs")
    parser.add_argument("--session", default="check", type=session_name)
    parser.set_defaults(handler=check)


def check(args: argparse.Namespace, console) -> int:
    from nodes.check.findings import check_passed
    from nodes.check.harness import CheckPlan, run_check
    from nodes.check.node_plan import master_kill_frame
    from nodes.check.table import check_table

    node_walls = _cave_nodes(args.cave) if args.cave else {w: (w,) for w in
                                                            wall_names(args.walls)}
    walls = tuple(node_walls)
    if args.every_kind:
        try:
            args.inject = [*every_kind(args.frames, walls), *args.inject]
        except ValueError as e:
            raise UsageError(f"cavesim check: error: argument --every-kind: {e}") from e
    for f in args.inject:
        if f.node is not None and f.node not in walls:
            raise UsageError(f"cavesim check: error: argument --inject: node {f.node!r} of "
                             f"{f} is not one of the nodes {', '.join(walls)}")
        if f.kind in COLLISIONS and len(walls) < MIN_COLLISION_WALLS:
            raise UsageError(f"cavesim check: error: argument --inject: {f} needs at least "
                             f"{MIN_COLLISION_WALLS} walls (a second healthy wall besides "
                             f"the source), got {len(walls)}")
        if f.frame > args.frames:
            raise UsageError(f"cavesim check: error: argument --inject: {f} is after the "
                             f"last frame {args.frames}")
        if f.kind == "control-forgery" and f.frame + len(CONTROL_REQUESTS) - 1 > args.frames:
            raise UsageError(f"cavesim check: error: argument --inject: {f} asks "
                             f"{', '.join(CONTROL_REQUESTS)} on frames {f.frame} to "
                             f"{f.frame + len(CONTROL_REQUESTS) - 1}, after the last frame "
                             f"{args.frames}")
        if (last := divergence_frames(f)[-1]) > args.frames:
            raise UsageError(f"cavesim check: error: argument --inject: {f} makes its node "
                             f"diverge again at frame {last}, after the last frame "
                             f"{args.frames}")
        if (last := last_action(f)) > args.frames:
            raise UsageError(f"cavesim check: error: argument --inject: {f} restarts its node "
                             f"at frame {last}, after the last frame {args.frames}")
    try:
        master_kill_frame(tuple(args.inject))
    except ValueError as e:
        raise UsageError(f"cavesim check: error: argument --inject: {e}") from e
    if any(f.kind == "master-kill" and f.frame < 2 for f in args.inject):
        raise UsageError("cavesim check: error: argument --inject: master-kill needs FRAME "
                         ">= 2 (a master that ran at least one frame)")
    configure_logging(False)
    with own_folder(args.out, "check", args.force) as folder:
        plan = CheckPlan(walls, args.scene, args.frames, tuple(args.inject), folder.path,
                         args.session, args.barrier_timeout, on_loss=args.on_loss,
                         check_every=args.check_every, resync=args.resync,
                         node_walls=node_walls, **limits_from(args))
        with Progress(console=console) as progress:
            task = progress.add_task(f"check, {len(walls)} nodes", total=args.frames)
            report = run_check(plan, lambda k, live: progress.update(task, completed=k))
        path = folder.path / "check.json"
        with writing(path):
            path.write_text(json.dumps(report, indent=2) + "\n")
    console.print(check_table(report))
    check_written(path)
    console.print(f"wrote {path}")
    return 0 if check_passed(report, bool(args.inject)) else RUN_ERROR


def _cave_nodes(path: Path) -> dict[str, tuple[str, ...]]:
    from cavesim.core.cave.geometry import load_cave
    from cavesim.core.errors import CaveError

    try:
        return load_cave(path).nodes
    except CaveError as e:
        raise UsageError(f"cavesim check: error: argument --cave: {e}") from e
