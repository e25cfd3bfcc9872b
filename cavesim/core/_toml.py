"""Reading a TOML input file, with every failure turned into the caller's error class.

The file must be a regular file of at most MAX_TOML_BYTES (`cavesim.core.input_files`).
Nesting is bounded: `tomllib` recurses once per level of an array or inline table and
fails with a RecursionError past Python's limit, and a table nested by dotted keys is
as deep as it has parts. No cavesim file needs more than a few levels (the shipped ones
reach 6), so a file deeper than MAX_NESTING is refused with one line before any reader
walks it.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from cavesim.core.input_files import read_input
from cavesim.core.limits import MAX_NESTING, MAX_TOML_BYTES


def read_toml(path: Path, error: type[Exception], what: str) -> dict[str, Any]:
    """The parsed file; `error` names the file and what is wrong with it."""
    text = read_input(path, error, what, MAX_TOML_BYTES)
    try:
        data = tomllib.loads(text.decode())
    except UnicodeDecodeError as e:
        raise error(f"{path}: not valid TOML: the file must be UTF-8 ({e})") from e
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path}: not valid TOML: {e}") from e
    except RecursionError:
        data = None
    if data is None or too_deep(data, MAX_NESTING + 1):  # the document is no level
        raise error(f"{path}: {what} nested deeper than {MAX_NESTING} levels (tables and "
                    f"arrays); at most {MAX_NESTING} are allowed")
    return data


def too_deep(value: Any, levels: int) -> bool:
    """Whether `value`, with the tables and arrays it holds, is more than `levels` deep."""
    children = value.values() if isinstance(value, dict) else \
        value if isinstance(value, list) else None
    if children is None:
        return False
    return levels == 0 or any(too_deep(child, levels - 1) for child in children)
