"""Each run owns its output folder, so two runs never write into one another's files.

Without `--out`, a run gets a fresh folder under out/ named by its command and start time
(`out/run-20261128-075812`), and out/latest points to the newest. A folder given with
`--out` must be new or empty; one that holds another run's files is refused with a hint,
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
from dataclasses import dataclass
from pathlib import Path

from nodes.arguments import UsageError, output_directory

MARKER = ".cavesim-run"  # JSON: the command, its process, host and start time
LOCK = ".cavesim-run.lock"
DEFAULT_ROOT = Path("out")
LATEST = "latest"  # out/latest: a link to the newest default folder
SHOWN = 4  # names of another run's files an error line shows


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
    lock = _locked(path, where)
    try:
        others = sorted(p.name for p in path.iterdir() if p.name not in (MARKER, LOCK))
        if others:
            _replace(path, others, force, where)
        (path / MARKER).write_text(json.dumps({
            "command": command, "pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.datetime.now().isoformat(timespec="seconds")}) + "\n")
    except BaseException:
        os.close(lock)
        raise
    return RunFolder(path, lock)


def link_latest(folder: Path, root: Path = DEFAULT_ROOT) -> None:
    """Point root/latest at `folder` (a sibling under root), replacing the link at once."""
    link, staged = root / LATEST, root / f".{LATEST}.{os.getpid()}"
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
