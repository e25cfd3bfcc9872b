"""`--trajectories N` and `--every K`: the flags of `cavesim run` and `cavesim replay` that
write trajectories.parquet (docs/trajectories.md), checked at the edge; and the flags by which
`cavesim run` asks one node to write it (`node_flags`, read back by `node_request`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from cavesim.core.limits import MAX_TRAJECTORIES
from nodes.arguments import UsageError, number_in, output_folder

MAX_EVERY = 10**9  # frames


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trajectories", type=number_in(int, 1, MAX_TRAJECTORIES, "particles"),
                        metavar="N",
                        help="write the tracks of about N evenly chosen particles to "
                             "trajectories.parquet (docs/trajectories.md)")
    parser.add_argument("--every", type=number_in(int, 1, MAX_EVERY, "frames"), metavar="K",
                        help="with --trajectories: a row every K frames (default 1)")


def requested(args: argparse.Namespace, command: str) -> tuple[int, int] | None:
    """(N, K) when --trajectories was given; --every alone is a usage error."""
    if args.trajectories is None:
        if args.every is not None:
            raise UsageError(f"cavesim {command}: error: argument --every: only with "
                             f"--trajectories N")
        return None
    return args.trajectories, args.every or 1


def add_node_arguments(parser: argparse.ArgumentParser) -> None:
    """`cavesim node`'s: the run's flags, its planned length and the folder to write in."""
    add_arguments(parser)
    parser.add_argument("--trajectory-frames", type=number_in(int, 1, 10**9, "frames"),
                        help="with --trajectories: the run's planned frames (the selection's "
                             "stride comes from them and --trajectory-dt)")
    parser.add_argument("--trajectory-dt", type=number_in(float, 1e-6, 1.0, "seconds"),
                        help="with --trajectories: the run's nominal dt")
    parser.add_argument("--trajectory-out", type=output_folder,
                        help="with --trajectories: the folder for trajectories.parquet")


def node_flags(count: int, every: int, frames: int, dt: float,
               folder: Path) -> tuple[str, ...]:
    return ("--trajectories", str(count), "--every", str(every), "--trajectory-frames",
            str(frames), "--trajectory-dt", repr(dt), "--trajectory-out", str(folder))


def node_request(args: argparse.Namespace):
    """What `node_flags` said, (TrajectoryRequest, folder), or None; a flag missing is a
    usage error."""
    from cavesim.core.trajectories import TrajectoryRequest  # pyarrow: only when asked

    tracks = requested(args, "node")
    if tracks is None:
        return None
    given = (args.trajectory_frames, args.trajectory_dt, args.trajectory_out)
    if None in given:
        raise UsageError("cavesim node: error: argument --trajectories: give "
                         "--trajectory-frames, --trajectory-dt and --trajectory-out too")
    return TrajectoryRequest(*tracks, *given[:2]), args.trajectory_out
