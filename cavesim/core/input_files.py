"""Opening a file an input names: a regular file within its size limit, or one line saying
what it is instead.

A scene names its base, field, height field and model files; a frame log's header names its
scene; each may name a FIFO (which would block a reader for ever), a device (`/dev/zero`
never ends) or a folder. The path is checked with `stat` before it is opened, opened
non-blocking (a FIFO swapped in after the check cannot block the open) and checked again on
the open file, whose size is then held to the caller's limit (`cavesim.core.limits`).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import BinaryIO

# What a path is, by its `stat` mode, in the words of an error
KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
         (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
         (stat.S_ISSOCK, "a socket"))


def open_input(path: Path, error: type[Exception], what: str, limit: int) -> BinaryIO:
    """`path` opened for reading in binary; `error` names the path, what it is and what is
    allowed when it is no regular file of at most `limit` bytes, or cannot be opened."""
    path = Path(path)
    try:
        status = os.stat(path)  # a symlink's target is what is read
    except (OSError, ValueError) as e:  # a ValueError: a NUL in the path
        raise _unreadable(path, what, error, e) from e
    _check(path, status, error, what, limit)  # a device is refused before it is opened
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as e:
        raise _unreadable(path, what, error, e) from e
    try:
        _check(path, os.fstat(descriptor), error, what, limit)  # replaced since its stat?
        os.set_blocking(descriptor, True)
        return os.fdopen(descriptor, "rb")
    except BaseException:
        os.close(descriptor)
        raise


def read_input(path: Path, error: type[Exception], what: str, limit: int) -> bytes:
    """The bytes of the file at `path` as it was when opened, as `open_input` allows it
    (what is appended since, as to a log being written, is not read)."""
    with open_input(path, error, what, limit) as file:
        size = os.fstat(file.fileno()).st_size
        try:
            return file.read(size)
        except OSError as e:
            raise _unreadable(Path(path), what, error, e) from e
        except MemoryError as e:
            raise error(f"{Path(path)}: {what} is {_bytes(size)}, more than this machine can "
                        f"hold in memory now") from e


def descriptor_path(file: BinaryIO) -> str:
    """A path that opens the very file `file` holds open (for a library that takes only a
    path), whatever was put at the name it was opened by since."""
    return f"/dev/fd/{file.fileno()}"


def not_regular(path: Path) -> str | None:
    """What `path` is, in words, when it is there but no regular file; else None."""
    try:
        status = os.stat(path)
    except (OSError, ValueError):
        return None
    return None if stat.S_ISREG(status.st_mode) else _kind(path, status)


def _kind(path: Path, status: os.stat_result) -> str:
    kind = next((name for test, name in KINDS if test(status.st_mode)), "no regular file")
    return f"a symlink to {kind}" if path.is_symlink() else kind


def _check(path: Path, status: os.stat_result, error: type[Exception], what: str,
           limit: int) -> None:
    if not stat.S_ISREG(status.st_mode):
        raise error(f"{path}: {what} is {_kind(path, status)}; only a regular file of at "
                    f"most {_bytes(limit)} is read")
    if status.st_size > limit:
        raise error(f"{path}: {what} is {_bytes(status.st_size)}; at most {_bytes(limit)} is "
                    f"read")


def _unreadable(path: Path, what: str, error: type[Exception], cause: Exception) -> Exception:
    return error(f"{path}: cannot read {what}: {getattr(cause, 'strerror', None) or cause}")


def _bytes(count: int) -> str:
    """A byte count in words: exact, and in MiB or GiB when that is shorter to read."""
    for unit, size in (("GiB", 2**30), ("MiB", 2**20)):
        if count >= size:
            return f"{count:,} bytes ({count / size:.4g} {unit})"
    return f"{count:,} bytes"
