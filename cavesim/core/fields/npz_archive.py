"""Reading cavesim's .npz archives (a flow field's, a height field's): each array's .npy
header is read and held to the most values its caller takes before any of its data is.

The archive is opened as `cavesim.core.input_files` opens any input: a regular file of at
most MAX_FIELD_FILE_BYTES. A header numpy cannot parse (truncated, nested, not a dict) and
an array larger than allowed are each one FieldError naming the file and the array.
"""

from __future__ import annotations

import math
import tokenize
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from cavesim.core.errors import FieldError
from cavesim.core.input_files import open_input
from cavesim.core.limits import MAX_FIELD_FILE_BYTES

# What reading a damaged archive or member raises (a compression zipfile lacks, an
# encrypted member: NotImplementedError, RuntimeError)
ARCHIVE_ERRORS = (OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError,
                  RuntimeError)
# What numpy's .npy header reader raises on a malformed header: its parser is Python's own
HEADER_ERRORS = (ValueError, SyntaxError, tokenize.TokenError, TypeError, OverflowError,
                 RecursionError)
HEADER_READERS = {(1, 0): npy_format.read_array_header_1_0,
                  (2, 0): npy_format.read_array_header_2_0}
MAX_ITEM_BYTES = 8  # of one value: no array cavesim reads holds wider numbers


class NpzArchive:
    """An .npz archive opened for reading its arrays one by one (a context manager)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._file = open_input(self.path, FieldError, "the .npz archive", MAX_FIELD_FILE_BYTES)
        try:
            if self._file.read(len(npy_format.MAGIC_PREFIX)) == npy_format.MAGIC_PREFIX:
                raise FieldError(f"{self.path}: is a single .npy array, expected an .npz "
                                 f"archive of named arrays")
            self._file.seek(0)
            self._zip = zipfile.ZipFile(self._file)
        except ARCHIVE_ERRORS as e:
            self._file.close()
            raise FieldError(f"{self.path}: cannot read as an .npz archive: {e}") from e
        except FieldError:
            self._file.close()
            raise
        self.names = tuple(name.removesuffix(".npy") for name in self._zip.namelist()
                           if name.endswith(".npy"))

    def shape(self, name: str) -> tuple[int, ...]:
        """The shape of array `name`, from its .npy header alone."""
        return self._header(name)[0]

    def array(self, name: str, most: int) -> np.ndarray:
        """Array `name`, read once its header shows at most `most` values of at most
        MAX_ITEM_BYTES each."""
        shape, dtype = self._header(name)
        if math.prod(shape) > most or dtype.itemsize > MAX_ITEM_BYTES:
            raise FieldError(f"{self.path}: array {name!r} has shape {shape} of {dtype}: "
                             f"{math.prod(shape):,} values; at most {most:,} numbers of at "
                             f"most {MAX_ITEM_BYTES} bytes each are read")
        try:
            with self._zip.open(f"{name}.npy") as member:
                return npy_format.read_array(member, allow_pickle=False)
        except ARCHIVE_ERRORS + (ValueError,) as e:
            raise FieldError(f"{self.path}: cannot read the array {name!r}: "
                             f"{_first_line(e)}") from e

    def _header(self, name: str) -> tuple[tuple[int, ...], np.dtype]:
        try:
            with self._zip.open(f"{name}.npy") as member:
                version = npy_format.read_magic(member)
                if version not in HEADER_READERS:
                    raise ValueError(f"format version {version}, expected "
                                     f"{' or '.join(map(str, HEADER_READERS))}")
                shape, _, dtype = HEADER_READERS[version](member)
        except ARCHIVE_ERRORS + HEADER_ERRORS as e:
            raise FieldError(f"{self.path}: array {name!r} has no readable .npy header "
                             f"({type(e).__name__}: {_first_line(e)})") from e
        if any(n < 0 for n in shape):
            raise FieldError(f"{self.path}: array {name!r} has shape {shape}; a shape has no "
                             f"negative length")
        return shape, dtype

    def close(self) -> None:
        self._zip.close()
        self._file.close()

    def __enter__(self) -> NpzArchive:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_npz(path: Path, required: Mapping[str, int],
             optional: Mapping[str, int] | None = None) -> dict[str, np.ndarray]:
    """The named arrays of an .npz archive, each held to the most values its name maps to;
    any read or format failure is a FieldError."""
    optional = optional or {}
    with NpzArchive(path) as archive:
        for name in required:
            if name not in archive.names:
                raise FieldError(f"{path}: missing array {name!r}; the archive holds "
                                 f"{list(archive.names)}, expected {tuple(required)} "
                                 f"(optional {tuple(optional)})")
        return {name: archive.array(name, most) for name, most in {**required, **optional}.items()
                if name in archive.names}


def _first_line(error: Exception, length: int = 200) -> str:
    """An error's message as one short line (numpy quotes a whole header, on lines)."""
    text = str(error).splitlines()[0] if str(error) else ""
    return text if len(text) <= length else text[:length] + "..."
