"""Parsing a JSON input (a frame log's header line, a glTF model's JSON) with its nesting
bounded before the parser sees it: `json` recurses once per level of an object or array and
fails with a RecursionError past Python's limit, so a document deeper than MAX_NESTING is
refused with one line, from a scan of its brackets outside strings.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np

from cavesim.core.limits import MAX_NESTING

_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)  # a JSON string, escapes and all
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")
_STEPS = bytes.maketrans(b"[{]}", b"\x01\x01\xff\xff")  # a level in (+1) or out (-1)
_CHUNK = 2**20  # brackets summed at once: the scan's memory stays small


def parse_json(data: bytes, error: type[Exception], where: str, what: str) -> Any:
    """The JSON document `data` (UTF-8); `error` names `where` and what is wrong with it."""
    if nesting(data) > MAX_NESTING:
        raise error(f"{where}: {what} nested deeper than {MAX_NESTING} levels (objects and "
                    f"arrays); at most {MAX_NESTING} are allowed")
    try:
        return json.loads(data)
    except ValueError as e:  # a JSONDecodeError or a UnicodeDecodeError
        raise error(f"{where}: {what} is not valid JSON: {e}") from e


def nesting(data: bytes) -> int:
    """How deep the objects and arrays of `data` nest (brackets inside strings aside)."""
    steps = np.frombuffer(_STRING.sub(b"", data).translate(_STEPS, _NOT_BRACKETS), np.int8)
    deepest = level = 0
    for start in range(0, len(steps), _CHUNK):
        levels = np.cumsum(steps[start:start + _CHUNK], dtype=np.int64) + level
        deepest, level = max(deepest, int(levels.max())), int(levels[-1])
    return deepest
