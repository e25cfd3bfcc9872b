"""`cavesim keys --out DIR --walls front,left --trackers dtrack --operators desk`: a new
session's key files: master.key for the master, and a key of its own for every wall, tracker
and operator, certified by the master's key (cavesim/core/wire/credentials.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from cavesim.core.wire.credentials import (
    MASTER_FILE,
    OPERATOR,
    TRACKER,
    WALL,
    generate,
    member_file,
)
from cavesim.core.wire.key_files import write_key_files
from nodes.arguments import UsageError, output_directory, wall_list


def add(commands) -> None:
    parser = commands.add_parser("keys", help="make a session's keys: master.key (the "
                                              "master's only) and one key per wall, tracker "
                                              "and operator")
    parser.add_argument("--out", type=Path, required=True,
                        help="folder for the key files (made if missing)")
    parser.add_argument("--walls", type=wall_list, required=True,
                        help="the walls' names, comma-separated: each gets wall-NAME.key")
    parser.add_argument("--trackers", type=wall_list, default=(),
                        help="the trackers' names, comma-separated: each gets "
                             "tracker-NAME.key")
    parser.add_argument("--operators", type=wall_list, default=(),
                        help="the operators' names, comma-separated: each gets "
                             "operator-NAME.key, the --operator-key-file of a `cavesim node "
                             "--preview` (only an operator's key may pause, reset or stop the "
                             "run)")
    parser.add_argument("--force", action="store_true",
                        help="replace key files that are there (every member then needs its "
                             "new key)")
    parser.set_defaults(handler=keys)


def keys(args: argparse.Namespace, console) -> int:
    output_directory(args.out, "keys")
    members = ((WALL, args.walls), (TRACKER, args.trackers), (OPERATOR, args.operators))
    names = [MASTER_FILE] + [member_file(role, name) for role, given in members
                             for name in given]
    there = [name for name in names if (args.out / name).exists()]
    if there and not args.force:
        raise UsageError(f"cavesim keys: error: argument --out: {args.out} already holds "
                         f"{', '.join(there)}; give another folder, or --force to replace "
                         f"them")
    try:
        written = write_key_files(args.out, generate(), tuple(args.walls), tuple(args.trackers),
                                  tuple(args.operators))
    except OSError as e:
        raise UsageError(f"cavesim keys: error: argument --out: cannot write the keys into "
                         f"{args.out}: {e.strerror or e}") from e
    console.print(f"wrote {written[0]} (the master's only: --key-file of `cavesim master` or "
                  f"`cavesim run`) and {', '.join(p.name for p in written[1:])} (each the "
                  f"--key-file of that wall's `cavesim node` or that `cavesim tracker`, "
                  f"an operator's the --operator-key-file of a `cavesim node --preview`)",
                  markup=False, soft_wrap=True)
    return 0
