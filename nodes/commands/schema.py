"""`cavesim schema [--out FILE]`: the reference of scene and CAVE files, every key with what
it allows, its default and what it means, written from the schemas the loaders check."""

from __future__ import annotations

import argparse
from pathlib import Path

from cavesim.tools.file_reference import REFERENCE_FILE, reference_text
from nodes.arguments import UsageError


def add(commands) -> None:
    parser = commands.add_parser("schema", help="print the reference of scene and CAVE files "
                                                "(every key, what it allows, its default)")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"write it to this file instead of printing it (the project's "
                             f"copy is {REFERENCE_FILE})")
    parser.set_defaults(handler=schema)


def schema(args: argparse.Namespace, console) -> int:
    text = reference_text()
    if args.out is None:
        print(text, end="")
        return 0
    try:
        args.out.write_text(text)
    except OSError as e:
        raise UsageError(f"cavesim schema: error: argument --out: cannot write {args.out}: "
                         f"{e.strerror or e}") from e
    console.print(f"wrote {args.out}", markup=False, soft_wrap=True)
    return 0
