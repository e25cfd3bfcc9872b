"""`cavesim master`: the master of a cluster of several hosts (`deploy/launch.sh`); flags in,
a typed `MasterConfig` out."""

from __future__ import annotations

import argparse
import json

from cavesim.core.wire.credentials import MASTER
from cavesim.tools.signals import release_start
from nodes.arguments import (
    DEFAULT_SCENE,
    INTERRUPTED,
    add_network_arguments,
    configure_logging,
    frame_count,
    lost_walls_code,
    network_and_key,
    number_in,
    output_file,
    output_path,
    scene_file,
    seconds,
    wall_list,
)
from nodes.budget_flags import add_arguments as add_budget_arguments
from nodes.budget_flags import limits_from
from nodes.lockstep import LOSS_POLICIES
from nodes.mixed_hardware import add_arguments as add_mixed_hardware_arguments
from nodes.mixed_hardware import tolerance_from


def add(commands) -> None:
    parser = commands.add_parser("master", help="the clock, the barrier and divergence handling")
    parser.add_argument("--walls", type=wall_list, required=True, help="e.g. front,left,floor")
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE)
    parser.add_argument("--frames", type=frame_count, default=600)
    parser.add_argument("--barrier-timeout", type=seconds, default=2.0)
    parser.add_argument("--join-timeout", type=seconds, default=60.0)
    parser.add_argument("--on-loss", choices=LOSS_POLICIES,
                        help="a wall lost (gone, or silent past --evict-after): continue "
                             "without it, or pause the barrier until it is back (at most "
                             "--max-pause). Default: continue, but the run then exits 1 when a "
                             "wall is lost for good; give --on-loss continue to accept that")
    parser.add_argument("--evict-after", type=seconds, default=10.0,
                        help="seconds a member may stay silent in the barrier before it is "
                             "evicted (--on-loss continue; default 10)")
    parser.add_argument("--max-pause", type=seconds, default=300.0,
                        help="seconds the barrier holds for a silent member under --on-loss "
                             "pause before the run ends (default 300)")
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
    parser.add_argument("--report", type=output_path, help="write the run's JSON report here "
                        "(divergence forensics go beside it, into divergences/)")
    parser.add_argument("--frame-log", type=output_path, help="record every frame's inputs here")
    parser.add_argument("--progress", action="store_true", help="JSON progress lines on stdout")
    parser.add_argument("--verbose", action="store_true")
    add_budget_arguments(parser)
    add_mixed_hardware_arguments(parser, master=True)
    add_network_arguments(parser)
    parser.set_defaults(handler=run, holds_start=True)  # until its report is open


def run(args: argparse.Namespace, console) -> int:
    from nodes.master.process import MasterConfig
    from nodes.master.process import main as run_master
    from nodes.master.report_file import ReportFile

    configure_logging(args.verbose)
    network, credentials = network_and_key(args, "master", MASTER)
    tolerance = tolerance_from(args, args.walls, "master")
    for flag, path in (("--report", args.report), ("--frame-log", args.frame_log)):
        if path is not None:
            output_file(path, "master", flag)
    config = MasterConfig(args.walls, args.scene, args.frames, args.session, network,
                          credentials, barrier_timeout=args.barrier_timeout,
                          join_timeout=args.join_timeout, on_loss=args.on_loss or "continue",
                          evict_after=args.evict_after, max_pause=args.max_pause,
                          check_every=args.check_every, tolerance=tolerance,
                          clock_seed=args.clock_seed, frame_log=args.frame_log, dt=args.dt,
                          realtime=args.realtime, max_frame_time=args.max_frame_time,
                          max_substeps=args.max_substeps,
                          forensics=args.report.parent if args.report else None,
                          **limits_from(args))

    def progress(k: int, live: int) -> None:
        if args.progress:
            print(json.dumps({"frame": k, "frames": args.frames, "live": live}), flush=True)

    if args.report is None:
        release_start()
        record = run_master(config, progress)
    else:
        with ReportFile(args.report) as report:
            release_start()  # a signal that came while it started is written into the report
            record = run_master(config, progress, report.checkpoint)
            report.finish(record.summary(), record.interrupted, record.user_stopped)
    if record.interrupted:
        return INTERRUPTED
    return lost_walls_code(record.final.lost if record.final else (), args.on_loss, "master")
