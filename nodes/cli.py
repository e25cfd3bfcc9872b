"""The `cavesim` command line: it owns every subcommand; argument parsing only, each
subcommand's module (`nodes.commands`) checks its flags and calls a typed function.

Bad input ends with a one-line error naming the flag, its value and what is allowed
(exit code 2); an error while running exits with 1; neither prints a traceback. A bug
ends with one line too; its traceback goes only to a log (stderr not a terminal) or where
CAVESIM_TRACEBACK is set.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Sequence
from typing import NoReturn

from cavesim.tools.signals import hold_start, release_start, stop_signals

TRACEBACK_VARIABLE = "CAVESIM_TRACEBACK"
PIPED_WIDTH = 120  # columns of output that is not a terminal


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse would print the usage and exit
        from nodes.arguments import UsageError

        raise UsageError(f"{self.prog}: error: {message}")


DESCRIPTION = ("cavesim keeps a GPU particle simulation identical on every wall of a CAVE. "
               "Each command below has its own --help.")

def build_parser() -> argparse.ArgumentParser:
    from nodes.commands import (
        bench,
        check,
        doctor,
        keys,
        master,
        node,
        numerics,
        render,
        replay,
        run,
        schema,
        tracker,
    )

    parser = _Parser(prog="cavesim", description=DESCRIPTION)
    parser.set_defaults(holds_start=False)
    commands = parser.add_subparsers(dest="command", required=True, metavar="command")
    for add in (bench.add, numerics.add_accuracy, numerics.add_stability, doctor.add, run.add,
                master.add, node.add, replay.add, render.add, check.add, tracker.add, keys.add,
                schema.add):
        add(commands)
    return parser


def _console():
    from rich.console import Console

    console = Console()
    if not console.is_terminal:  # a log or a pipe: rich would squeeze wide tables into 80
        console.width = max(console.width, PIPED_WIDTH)
    return console


def main(argv: Sequence[str] | None = None) -> int:
    """Run one `cavesim` command; return its exit code.

    A stopping signal (Ctrl-C, SIGTERM, SIGHUP) ends a command as Ctrl-C does from the
    first line on: while the command starts (these imports, its flags) it waits, until the
    command can say how it ended (`cavesim run` and `cavesim master --report` once their
    report is open: `holds_start`; every other command once its flags are read)."""
    with stop_signals():
        hold_start()
        from cavesim.core.errors import CavesimError
        from nodes.arguments import INTERRUPTED, RUN_ERROR, USAGE_ERROR, UsageError

        try:
            args = build_parser().parse_args(argv)
            if not args.holds_start:
                release_start()
            return args.handler(args, _console())
        except UsageError as e:
            print(e, file=sys.stderr)
            return USAGE_ERROR
        except KeyboardInterrupt:  # before the command could say so itself
            print("cavesim: interrupted", file=sys.stderr)
            return INTERRUPTED
        except CavesimError as e:
            print(f"cavesim: error: {e}", file=sys.stderr)
            return RUN_ERROR
        except Exception as e:  # a bug: one line for a person, the traceback for a log
            if os.environ.get(TRACEBACK_VARIABLE) or not sys.stderr.isatty():
                traceback.print_exc()
            print(f"cavesim: error: internal error, {type(e).__name__}: {e} (a bug; set "
                  f"{TRACEBACK_VARIABLE}=1 for the traceback)", file=sys.stderr)
            return RUN_ERROR
