"""`cavesim doctor`: what a CAVE administrator runs first on a new node."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console

from nodes.arguments import (
    RUN_ERROR,
    add_network_arguments,
    network_and_key,
    output_file,
    output_path,
)


def add(commands) -> None:
    parser = commands.add_parser(
        "doctor", help="what this node offers: EGL devices, GL limits, zenoh, windows; "
                       "exit 1 with the reason and the fix if it cannot run cavesim")
    parser.add_argument("--out", type=output_path, default=Path("out/doctor.json"),
                        help="where to write the findings as JSON (default: out/doctor.json)")
    add_network_arguments(parser)
    parser.set_defaults(handler=doctor)


def doctor(args: argparse.Namespace, console: Console) -> int:
    """`cavesim doctor`: check the flags as a node would, then `run_doctor`."""
    from cavesim.tools.doctor.report import run_doctor

    network, _ = network_and_key(args, "doctor")  # a zenoh config is checked there
    output_file(args.out, "doctor", "--out")
    verdict = run_doctor(network, args.out, console)
    if verdict.ok:
        return 0
    print(f"cavesim doctor: this node cannot run cavesim: {verdict.reason}; fix: {verdict.fix}",
          file=sys.stderr)
    return RUN_ERROR
