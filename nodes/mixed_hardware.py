"""The mixed-hardware flags of `cavesim run`, `cavesim master` and `cavesim node`, defined
once: `--mixed-hardware` turns the tolerance mode on (`nodes/master/tolerance.py`), and
its settings are refused without it, so that no run is weaker than bit-exact by accident."""

from __future__ import annotations

import argparse

from cavesim.core.drift import DEFAULT_SAMPLE, MAX_SAMPLE
from cavesim.core.wire.key_expressions import check_name
from nodes.arguments import UsageError, number_in
from nodes.master.tolerance import (
    DEFAULT_POSITION_TOLERANCE,
    DEFAULT_RESYNC_EVERY,
    DEFAULT_VELOCITY_TOLERANCE,
    RESYNC_EVERY_RANGE,
    TOLERANCE_RANGE,
    Tolerance,
)

MASTER_FLAGS = ("authority", "resync_every", "position_tolerance", "velocity_tolerance")


def wall_name(text: str) -> str:
    try:
        return check_name("wall", text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from e


def add_arguments(parser: argparse.ArgumentParser, master: bool) -> None:
    """The mode's flags: the sample size for every process, the rest for the master's."""
    group = parser.add_argument_group(
        "mixed hardware", "GPUs whose bits cannot agree: compare the walls with an authority "
                          "by a tolerance on positions and velocities instead of by checksum")
    group.add_argument("--mixed-hardware", action="store_true",
                       help="the tolerance mode (default: bit-exact; the master and every "
                            "node must be given it)")
    group.add_argument("--drift-sample", type=number_in(int, 1, MAX_SAMPLE, "records"),
                       help=f"live particles each node reads into its report to compare "
                            f"(evenly spaced; default {DEFAULT_SAMPLE})")
    if not master:
        return
    group.add_argument("--authority", type=wall_name,
                       help="the wall whose state is kept and sent to the others (default: "
                            "the first wall)")
    group.add_argument("--resync-every", type=number_in(int, *RESYNC_EVERY_RANGE, "frames"),
                       help=f"send the authority's state to each wall whose bits differ "
                            f"every K frames (default {DEFAULT_RESYNC_EVERY})")
    group.add_argument("--position-tolerance", type=number_in(float, *TOLERANCE_RANGE, "m"),
                       help=f"largest |Δposition| from the authority before a resync "
                            f"(default {DEFAULT_POSITION_TOLERANCE:g} m)")
    group.add_argument("--velocity-tolerance", type=number_in(float, *TOLERANCE_RANGE, "m/s"),
                       help=f"largest |Δvelocity| from the authority before a resync "
                            f"(default {DEFAULT_VELOCITY_TOLERANCE:g} m/s)")


def tolerance_from(args: argparse.Namespace, walls: tuple[str, ...],
                   command: str) -> Tolerance | None:
    """The master's tolerance settings (None: bit-exact); UsageError for a setting without
    --mixed-hardware or an authority that is not one of `walls`."""
    _only_with_the_mode(args, ("drift_sample", *MASTER_FLAGS), command)
    if not args.mixed_hardware:
        return None
    authority = args.authority or walls[0]
    if authority not in walls:
        raise UsageError(f"cavesim {command}: error: argument --authority: {authority!r} is "
                         f"not a wall of this run; choose one of {', '.join(walls)}")
    return Tolerance(authority, _or(args.resync_every, DEFAULT_RESYNC_EVERY),
                     _or(args.drift_sample, DEFAULT_SAMPLE),
                     _or(args.position_tolerance, DEFAULT_POSITION_TOLERANCE),
                     _or(args.velocity_tolerance, DEFAULT_VELOCITY_TOLERANCE))


def node_sample_from(args: argparse.Namespace, command: str) -> int:
    """Records a node samples into each report (0: bit-exact, none)."""
    _only_with_the_mode(args, ("drift_sample",), command)
    return _or(args.drift_sample, DEFAULT_SAMPLE) if args.mixed_hardware else 0


def node_arguments(tolerance: Tolerance | None) -> tuple[str, ...]:
    """The node flags that match the master's `tolerance` (none for bit-exact)."""
    if tolerance is None:
        return ()
    return ("--mixed-hardware", "--drift-sample", str(tolerance.sample))


def _only_with_the_mode(args: argparse.Namespace, names: tuple[str, ...], command: str) -> None:
    given = next((name for name in names if getattr(args, name) is not None), None)
    if given is not None and not args.mixed_hardware:
        raise UsageError(f"cavesim {command}: error: argument --{given.replace('_', '-')}: "
                         f"only with --mixed-hardware (without it every bit is compared)")


def _or(value, default):
    return default if value is None else value
