"""What every `cavesim` command shares at its edge: argument types with one-line errors,
the output folder made before any work, logging, the network flags, and the flags of
`cavesim run`, `replay` and `node` that write trajectories.parquet."""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
from pathlib import Path

from cavesim.core.framelog import FRAME_LOG
from cavesim.core.limits import DEFAULT_MASTER_PORT, MAX_TRAJECTORIES
from cavesim.core.wire.credentials import MASTER, Credentials
from cavesim.core.wire.key_expressions import check_name
from cavesim.core.wire.key_files import read_key_file
from cavesim.core.wire.network import NetworkSettings, zenoh_config
from nodes.faults import KINDS, NODE_PARTS, Fault, parse_fault

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENE = "config/scenes/brownout.toml"  # the demo
USAGE_ERROR, RUN_ERROR, INTERRUPTED = 2, 1, 130
CAVE_WALL_NAMES = ("front", "left", "right", "floor", "ceiling", "back")
MAX_WALLS = 64
MAX_EVERY = 10**9  # frames between two rows of trajectories.parquet


class UsageError(Exception):
    """Bad command-line input; the message is the whole line to print."""


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


frame_count = number_in(int, 1, 10**9, "a whole number of frames")
seconds = number_in(float, 1e-3, 3600.0, "seconds")


def frame_range(text: str) -> tuple[int, int | None]:
    """An argparse type: frames `A:B` (both included), `A:` (to the end) or `:B` (from
    frame 1); B None for the end."""
    first, colon, last = text.partition(":")
    try:
        span = (frame_count(first) if first else 1, frame_count(last) if last else None)
    except argparse.ArgumentTypeError:
        span = None
    if not colon or span is None or (span[1] is not None and span[1] < span[0]):
        raise argparse.ArgumentTypeError(f"expected frames A:B, A: or :B with 1 <= A <= B, "
                                         f"got {text!r}")
    return span
wall_count = number_in(int, 1, MAX_WALLS, "a number of walls")


def existing_file(what: str):
    """An argparse type: an existing `what` file, relative to the current directory, else
    to the repository."""

    def check(text: str) -> Path:
        path = Path(text)
        for candidate in (path, REPO_ROOT / path):
            if candidate.is_file():
                return candidate
        raise argparse.ArgumentTypeError(
            f"no {what} file {text!r} in the current directory or in {REPO_ROOT}; "
            f"give the path of a {what} .toml file")

    return check


scene_file = existing_file("scene")
cave_file = existing_file("CAVE")


def fault_spec(text: str) -> Fault:
    """A fault to inject, `KIND@FRAME[:NODE]` (`nodes/faults.py`)."""
    try:
        return parse_fault(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def node_fault_spec(text: str) -> Fault:
    """A fault a node injects into itself: a kind's, or its part of the harness's attacks."""
    try:
        return parse_fault(text, KINDS + NODE_PARTS)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def wall_list(text: str) -> tuple[str, ...]:
    """An argparse type: unique comma-separated wall names."""
    try:
        walls = tuple(check_name("wall", name) for name in text.split(","))
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected comma-separated wall names: {e}") from e
    if len(set(walls)) != len(walls):
        raise argparse.ArgumentTypeError(f"wall names must be unique, got {text!r}")
    return walls


def wall_names(count: int) -> tuple[str, ...]:
    """Names of `count` walls: the CAVE's own names first, then wall7, wall8, ..."""
    return tuple(CAVE_WALL_NAMES[i] if i < len(CAVE_WALL_NAMES) else f"wall{i + 1}"
                 for i in range(count))


def frame_log_path(path: Path, command: str) -> Path:
    """The frame log a command reads: `path` itself, or the FRAME_LOG in the run's folder
    `path`; a UsageError naming the positional argument when there is none."""
    if path.is_dir():
        if not (path / FRAME_LOG).is_file():
            raise UsageError(f"cavesim {command}: error: argument log: folder {str(path)!r} "
                             f"holds no {FRAME_LOG}; give a run's folder or its frame log")
        path = path / FRAME_LOG
    if not path.exists():  # what is there is read as `read_frame_log` allows, or named
        raise UsageError(f"cavesim {command}: error: argument log: no file {str(path)!r}")
    return path


def output_folder(text: str) -> Path:
    """An argparse type: an output folder (--out), refused at once if it is a file; the
    command makes it (`output_directory`) once its other flags are checked."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(_is_a_file(path))
    return path


def output_path(text: str) -> Path:
    """An argparse type: an output file (--report), refused at once if it is a folder or
    its folder is a file."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{str(path)!r} is a folder; give the path of a file")
    folder = next((p for p in path.parents if p.exists()), None)
    if folder is not None and not folder.is_dir():
        raise argparse.ArgumentTypeError(f"{str(path)!r}: {str(folder)!r} is a file, not a "
                                         f"folder; give a path in a folder")
    return path


def output_directory(path: Path, command: str, flag: str = "--out") -> Path:
    """Make the output directory and try a file in it before any work, so a bad one costs
    no run."""
    if path.exists() and not path.is_dir():
        raise UsageError(f"cavesim {command}: error: argument {flag}: {_is_a_file(path)}")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as e:
        raise UsageError(f"cavesim {command}: error: argument {flag}: cannot write in directory "
                         f"{str(path)!r}: {e.strerror or e}; give a writable directory") from e
    return path


def output_file(path: Path, command: str, flag: str) -> Path:
    """`output_directory` for a file's folder; a path that is a directory is refused."""
    try:
        output_path(str(path))
    except argparse.ArgumentTypeError as e:
        raise UsageError(f"cavesim {command}: error: argument {flag}: {e}") from e
    output_directory(path.parent, command, flag)
    return path


def _is_a_file(path: Path) -> str:
    return f"{str(path)!r} is a file; give a folder (a new one is made)"


def session_name(text: str) -> str:
    """An argparse type: a session name (1-32 letters, digits, '_' or '-')."""
    try:
        return check_name("session", text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """The network flags every cavesim process takes."""
    group = parser.add_argument_group("network (zenoh)")
    group.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                       help=f"endpoint to listen on, e.g. tcp/127.0.0.1:{DEFAULT_MASTER_PORT} "
                            "(repeatable)")
    group.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                       help=f"endpoint to connect to, e.g. tcp/10.0.0.1:{DEFAULT_MASTER_PORT} "
                            "(repeatable)")
    group.add_argument("--config", type=Path, dest="zenoh_config", metavar="FILE",
                       help="zenoh JSON5 config file (see config/zenoh/)")
    group.add_argument("--session", default="default", type=session_name,
                       help="session name: the key prefix")
    group.add_argument("--key-file", type=Path, metavar="FILE",
                       help="this process's key from `cavesim keys`: master.key for the "
                            "master, wall-WALL.key for a wall's node, tracker-NAME.key for a "
                            "tracker (mode 0600)")


def network_settings(args: argparse.Namespace) -> NetworkSettings:
    """The network flags' settings, checked: a config file that zenoh cannot read is
    refused here, before anything starts (ValueError, one line)."""
    settings = NetworkSettings(tuple(args.listen), tuple(args.connect), args.zenoh_config)
    try:
        zenoh_config(settings)
    except ValueError as e:
        raise ValueError(f"--config {e}") from e
    return settings


def read_key(path: Path | None, role: str, name: str | None = None) -> Credentials | None:
    """The credentials of `role` (member `name`, where given) from a --key-file (None
    without one); ValueError names the file and what is wrong, e.g. another role's key."""
    return None if path is None else read_key_file(path, role, name)


def network_and_key(args: argparse.Namespace, command: str, role: str | None = None,
                    name: str | None = None):
    """The zenoh settings and this process's key from the network flags (UsageError); the
    key must be that of `role` (and member `name`), and with no role it is not read."""
    try:
        key = None if role is None else read_key(args.key_file, role, name)
        return network_settings(args), key
    except ValueError as e:
        raise UsageError(f"cavesim {command}: error: {e}") from e


def master_credentials(path: Path | None, command: str):
    """The master's credentials from its --key-file (None without one): a master.key, else
    UsageError naming the file."""
    try:
        return read_key(path, MASTER)
    except ValueError as e:
        raise UsageError(f"cavesim {command}: error: {e}") from e


def add_trajectory_arguments(parser: argparse.ArgumentParser) -> None:
    """`--trajectories N` and `--every K` (docs/trajectories.md), of `cavesim run` and
    `cavesim replay`."""
    parser.add_argument("--trajectories", type=number_in(int, 1, MAX_TRAJECTORIES, "particles"),
                        metavar="N",
                        help="write the tracks of about N evenly chosen particles to "
                             "trajectories.parquet (docs/trajectories.md)")
    parser.add_argument("--every", type=number_in(int, 1, MAX_EVERY, "frames"), metavar="K",
                        help="with --trajectories: a row every K frames (default 1)")


def trajectories_requested(args: argparse.Namespace, command: str) -> tuple[int, int] | None:
    """(N, K) when --trajectories was given; --every alone is a usage error."""
    if args.trajectories is None:
        if args.every is not None:
            raise UsageError(f"cavesim {command}: error: argument --every: only with "
                             f"--trajectories N")
        return None
    return args.trajectories, args.every or 1


def add_node_trajectory_arguments(parser: argparse.ArgumentParser) -> None:
    """`cavesim node`'s: the run's flags, its planned length and the folder to write in, by
    which `cavesim run` asks one node to write the file (`trajectory_node_flags`)."""
    add_trajectory_arguments(parser)
    parser.add_argument("--trajectory-frames", type=number_in(int, 1, 10**9, "frames"),
                        help="with --trajectories: the run's planned frames (the selection's "
                             "stride comes from them and --trajectory-dt)")
    parser.add_argument("--trajectory-dt", type=number_in(float, 1e-6, 1.0, "seconds"),
                        help="with --trajectories: the run's nominal dt")
    parser.add_argument("--trajectory-out", type=output_folder,
                        help="with --trajectories: the folder for trajectories.parquet")


def trajectory_node_flags(count: int, every: int, frames: int, dt: float,
                          folder: Path) -> tuple[str, ...]:
    return ("--trajectories", str(count), "--every", str(every), "--trajectory-frames",
            str(frames), "--trajectory-dt", repr(dt), "--trajectory-out", str(folder))


def trajectory_node_request(args: argparse.Namespace):
    """What `trajectory_node_flags` said, (TrajectoryRequest, folder), or None; a flag
    missing is a usage error."""
    from cavesim.core.trajectories import TrajectoryRequest  # pyarrow: only when asked

    tracks = trajectories_requested(args, "node")
    if tracks is None:
        return None
    given = (args.trajectory_frames, args.trajectory_dt, args.trajectory_out)
    if None in given:
        raise UsageError("cavesim node: error: argument --trajectories: give "
                         "--trajectory-frames, --trajectory-dt and --trajectory-out too")
    return TrajectoryRequest(*tracks, *given[:2]), args.trajectory_out


def lost_walls_code(lost, on_loss: str | None, command: str) -> int:
    """The exit code of a run that ended with the walls `lost` out of the lock-step: 0 when
    none was, or when `--on-loss continue` was asked for explicitly; else RUN_ERROR with the
    one line that says so."""
    if not lost or on_loss == "continue":
        return 0
    print(f"cavesim {command}: error: wall(s) {', '.join(lost)} lost for good: the run ended "
          f"without them (see the report's losses); give --on-loss continue to accept that",
          file=sys.stderr)
    return RUN_ERROR


def configure_logging(verbose: bool) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, stream=sys.stderr,
                        format="%(asctime)s %(name)s %(levelname)s %(message)s")
