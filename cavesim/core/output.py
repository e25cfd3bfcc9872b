"""Writing result files so that a crash or a full disk never leaves a claim that is not
true: report.json is replaced whole (`write_atomically`), a failed write is one
`OutputError` naming the file (`writing`), and a file is said to be written only if it is
there (`check_written`)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from cavesim.core.errors import OutputError


@contextmanager
def writing(path: Path) -> Iterator[None]:
    """An OSError inside (ENOSPC, EDQUOT, EROFS, EACCES, a deleted folder) becomes an
    OutputError naming the file it names, else `path`."""
    try:
        yield
    except OSError as e:
        where = Path(e.filename if isinstance(e.filename, str | Path) else path)
        raise OutputError(f"cannot write {where}: {_reason(where, e.strerror or str(e))}") \
            from e


def write_atomically(path: Path, text: str) -> None:
    """Replace `path` by `text` so that a reader, or a crash at any moment, finds the old
    content or the new one whole: a temporary file in the same folder, fsynced, renamed
    over `path`, and the folder fsynced so that the rename survives a power loss too."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with writing(path):
        try:
            with open(temporary, "w") as file:
                file.write(text)
                file.flush()
                os.fsync(file.fileno())
            os.replace(temporary, path)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise
        folder = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(folder)
        finally:
            os.close(folder)


def check_written(*paths: Path) -> None:
    """OutputError for the first of `paths` that is not there (deleted after it was written)."""
    for path in map(Path, paths):
        if not path.exists():
            raise OutputError(f"{path} is missing: {_reason(path, 'deleted after it was written')}")


def _reason(path: Path, otherwise: str) -> str:
    return f"its folder {path.parent} is gone" if not path.parent.is_dir() else otherwise
