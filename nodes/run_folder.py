"""Each run owns its output folder, so two runs never write into one another's files.

Every command that writes result files (run, check, bench, accuracy, stability, render)
takes `--out` and `--force` from `add_arguments` and writes only inside `own_folder`.
Without `--out`, a run gets a fresh folder under out/ named by its command and start time
(`out/run-20261128-075812`), and a link points to the newest of that command: out/latest
for `cavesim run` (the one most people look for), out/<command>-latest for the others, so
a bench never moves the link to the last run. A folder given with `--out` must be new or
empty; one that holds another run's files is refused with a hint,
and `--force` replaces it only where a cavesim run wrote it (its MARKER file says so). While
a run writes, it holds an exclusive lock on the folder's LOCK file: a second run in the same
folder is refused at once, and a run that dies (a crash, a power cut) leaves no lock behind,
since the system drops a dead process's locks.
"""

from __future__ import annotations

import datetime
import fcntl
import json
import os
import shutil
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from nodes.arguments import UsageError, output_directory, output_folder

MARKER = ".cavesim-run"  # JSON: the command, its process, host and start time
LOCK = ".cavesim-run.lock"
DEFAULT_ROOT = Path("out")
LATEST = "latest"  # out/latest: a link to `cavesim run`'s newest default folder
SHOWN = 4  # names of another run's files an error line shows


def latest_name(command: str) -> str:
    """The name of the link to `command`'s newest default folder, beside it under out/."""
    return LATEST if command == "run" else f"{command}-{LATEST}"


def add_arguments(parser, command: str, holds: str) -> None:
    """`--out` and `--force` of a command whose run writes `holds` into its own folder."""
    parser.add_argument("--out", type=output_folder,
                        help=f"the folder for {holds}: new or empty (default: a fresh one, "
                             f"{DEFAULT_ROOT}/{command}-DATE-TIME, and "
                             f"{DEFAULT_ROOT}/{latest_name(command)} points to it)")
    parser.add_argument("--force", action="store_true",
                        help="with --out: replace the files an earlier cavesim run left there")


@contextmanager
def own_folder(out: Path | None, command: str, force: bool = False) -> Iterator[RunFolder]:
    """The folder a run of `command` writes, claimed for it: `out`, or a fresh default
    folder that the command's latest link then points to."""
    if force and out is None:
        raise UsageError(f"cavesim {command}: error: argument --force: replaces the files in "
                         "the folder --out names; give --out too")
    with claim(out or default_folder(command), command, force) as folder:
        if out is None:
            link_latest(folder.path, command)
        yield folder


def default_folder(command: str, now: datetime.datetime | None = None,
                   root: Path = DEFAULT_ROOT) -> Path:
    """A new folder under `root` for a run of `command` started `now` (a suffix -2, -3 ...
    where two start in one second)."""
    stamp = (now or datetime.datetime.now()).strftime("%Y%m%d-%H%M%S")
    folder = root / f"{command}-{stamp}"
    n = 2
    while folder.exists():
        folder = root / f"{command}-{stamp}-{n}"
        n += 1
    return folder


@dataclass
class RunFolder:
    """A claimed output folder: its lock is held until `release` (or the process ends)."""

    path: Path
    _lock: int

    def release(self) -> None:
        if self._lock >= 0:
            os.close(self._lock)  # closing the descriptor drops the lock
            self._lock = -1

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def claim(path: Path, command: str, force: bool = False, flag: str = "--out") -> RunFolder:
    """Make `path` this run's own: refuse a folder another run is writing, or one holding
    other files (with `force`, replace a cavesim run's); then lock it and mark it."""
    where = f"cavesim {command}: error: argument {flag}"
    output_directory(path, command, flag)
    lock_was_there = (path / LOCK).exists()
    lock = _locked(path, where)
    try:
        others = sorted(p.name for p in path.iterdir() if p.name not in (MARKER, LOCK))
        if others:
            _replace(path, others, force, where)
        (path / MARKER).write_text(json.dumps({
            "command": command, "pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.datetime.now().isoformat(timespec="seconds")}) + "\n")
    except BaseException:
        if not lock_was_there:  # a refused folder keeps nothing of this run
            (path / LOCK).unlink(missing_ok=True)
        os.close(lock)
        raise
    return RunFolder(path, lock)


def link_latest(folder: Path, command: str) -> None:
    """Point `command`'s latest link, beside `folder`, at it, replacing the link at once."""
    name = latest_name(command)
    link, staged = folder.parent / name, folder.parent / f".{name}.{os.getpid()}"
    staged.unlink(missing_ok=True)
    staged.symlink_to(folder.name, target_is_directory=True)
    os.replace(staged, link)


def _locked(path: Path, where: str) -> int:
    """The folder's lock, held; a UsageError naming the run that holds it already."""
    fd = os.open(path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise UsageError(f"{where}: {str(path)!r} is in use by another run ({_owner(path)}); "
                         "give another folder") from None
    return fd


def _owner(path: Path) -> str:
    try:
        marker = json.loads((path / MARKER).read_text())
        return (f"cavesim {marker['command']}, pid {marker['pid']} on {marker['host']}, "
                f"since {marker['started']}")
    except (OSError, ValueError, KeyError, TypeError):
        return "its marker unreadable"


def _replace(path: Path, others: list[str], force: bool, where: str) -> None:
    shown = ", ".join(others[:SHOWN]) + (", ..." if len(others) > SHOWN else "")
    if not force:
        raise UsageError(f"{where}: {str(path)!r} holds another run's files ({shown}); give a "
                         "new folder, leave --out off for a fresh one under out/, or add "
                         "--force to replace them")
    if not (path / MARKER).is_file():
        raise UsageError(f"{where}: {str(path)!r} holds files a cavesim run did not write "
                         f"({shown}); --force replaces only a run's own folder: give a new "
                         "folder")
    for name in others:
        entry = path / name
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()
