"""`cavesim keys --out DIR`: a new session's key files, master.key for the master and
session.key for every node and tracker (cavesim/core/wire/credentials.py)."""

from __future__ import annotations

import argparse
from pathlib import Path

from cavesim.core.wire.credentials import MASTER_FILE, SESSION_FILE, write_key_files
from nodes.arguments import UsageError, output_directory


def add(commands) -> None:
    parser = commands.add_parser("keys", help="make a session's keys: master.key (the "
                                              "master's only) and session.key (nodes, trackers)")
    parser.add_argument("--out", type=Path, required=True,
                        help="folder for master.key and session.key (made if missing)")
    parser.add_argument("--force", action="store_true",
                        help="replace key files that are there (every member then needs the "
                             "new session.key)")
    parser.set_defaults(handler=keys)


def keys(args: argparse.Namespace, console) -> int:
    output_directory(args.out, "keys")
    there = [name for name in (MASTER_FILE, SESSION_FILE) if (args.out / name).exists()]
    if there and not args.force:
        raise UsageError(f"cavesim keys: error: argument --out: {args.out} already holds "
                         f"{' and '.join(there)}; give another folder, or --force to replace "
                         f"them")
    try:
        master, session = write_key_files(args.out)
    except OSError as e:
        raise UsageError(f"cavesim keys: error: argument --out: cannot write the keys into "
                         f"{args.out}: {e.strerror or e}") from e
    console.print(f"wrote {master} (the master's only: --key-file of `cavesim master` or "
                  f"`cavesim run`) and {session} (--key-file of every `cavesim node` and "
                  f"`cavesim tracker`)", markup=False, soft_wrap=True)
    return 0
