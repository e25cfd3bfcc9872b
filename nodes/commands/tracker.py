"""`cavesim tracker`: the DTrack bridge as a process of its own; flags in, a typed config out,
its counts on the terminal (and as JSON with --report) when it ends."""

from __future__ import annotations

import argparse
import json

from cavesim.core.errors import TrackerError
from cavesim.core.output import writing
from cavesim.core.wire.credentials import TRACKER
from nodes.arguments import (
    UsageError,
    add_network_arguments,
    configure_logging,
    existing_file,
    network_and_key,
    number_in,
    output_file,
    output_path,
)

DEFAULT_MAP = "config/tracking/dtrack.toml"
MAX_RATE = 10000.0  # messages per second: far beyond any tracker


def add(commands) -> None:
    parser = commands.add_parser("tracker", help="publish an ART DTrack2 system's head and "
                                                 "wand (ASCII UDP) on the session")
    parser.add_argument("--dtrack", type=number_in(int, 1, 65535, "a UDP port"), required=True,
                        metavar="PORT", help="UDP port DTrack2 sends its output to")
    parser.add_argument("--bind", default="0.0.0.0", metavar="ADDR",
                        help="address of this host to receive on (default: all)")
    parser.add_argument("--map", type=existing_file("tracker mapping"), default=DEFAULT_MAP,
                        metavar="FILE", help=f"which bodies are head and wand, and DTrack's "
                                             f"room in the CAVE (default: {DEFAULT_MAP})")
    parser.add_argument("--max-rate", type=number_in(float, 0.0, MAX_RATE, "messages per second"),
                        default=0.0, metavar="HZ",
                        help="publish at most HZ messages per second (default 0: one per "
                             "datagram)")
    parser.add_argument("--report", type=output_path,
                        help="write the counts as JSON here at the end")
    parser.add_argument("--verbose", action="store_true")
    add_network_arguments(parser)
    parser.set_defaults(handler=tracker)


def tracker(args: argparse.Namespace, console) -> int:
    from cavesim.core.tracking import load_mapping
    from nodes.tracker.bridge import TrackerConfig
    from nodes.tracker.bridge import main as run_tracker

    configure_logging(args.verbose)
    network, key = network_and_key(args, "tracker", TRACKER)
    try:
        mapping = load_mapping(args.map)
    except TrackerError as e:
        raise UsageError(f"cavesim tracker: error: argument --map: {e}") from e
    if args.report:
        output_file(args.report, "tracker", "--report")
    counts = run_tracker(TrackerConfig(args.dtrack, mapping, args.bind, args.session, network,
                                       key, args.max_rate))
    console.print(f"tracker: {counts.datagrams} datagrams, {counts.published} published; "
                  f"rejected: {_by_name(counts.rejected)}; missing (last pose kept): "
                  f"{_by_name(counts.missing)}", markup=False, soft_wrap=True)
    if args.report:
        with writing(args.report):
            args.report.write_text(json.dumps(counts.summary(), indent=2) + "\n")
    return 0


def _by_name(counts) -> str:
    """Counts as text, e.g. "head 3, wand 1", or "none"."""
    return ", ".join(f"{name} {n}" for name, n in sorted(counts.items())) or "none"
