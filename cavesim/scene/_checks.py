"""Reusable validators for one TOML table of a scene, used by `_sections.py`.

Every check raises `SceneError` in one shape —
`<file>: <dotted.key> = <value!r> is not allowed: <what is allowed>` — so a user can find
the line in the scene file from the message alone.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

from cavesim.errors import SceneError

E = TypeVar("E", bound=Enum)


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


def bad_value(src: str, key: str, value: object, allowed: str) -> SceneError:
    """The error for `key = value` in `src`, saying what is allowed instead."""
    return SceneError(f"{src}: {key} = {value!r} is not allowed: {allowed}")


def _bounds(ge: float | None, gt: float | None, le: float | None, lt: float | None) -> str:
    kept = [f"{op} {b if isinstance(b, int) else format(b, 'g')}"
            for op, b in ((">=", ge), (">", gt), ("<=", le), ("<", lt)) if b is not None]
    return (" " + " and ".join(kept)) if kept else ""


def _in_bounds(x: float, ge: float | None, gt: float | None, le: float | None,
               lt: float | None) -> bool:
    return ((ge is None or x >= ge) and (gt is None or x > gt)
            and (le is None or x <= le) and (lt is None or x < lt))


def _as_float(value: object) -> float | None:
    """`value` as a finite float, or None when it is not a finite real number (bool is not)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        x = float(value)
    except OverflowError:  # an int beyond float range
        return None
    return x if math.isfinite(x) else None


class Table:
    """One scene table (a dict) with its dotted name; rejects keys not in `allowed` at once."""

    def __init__(self, src: str, key: str, data: object, allowed: Iterable[str]) -> None:
        self.src = src
        self.key = key
        self.allowed = tuple(allowed)
        if not isinstance(data, Mapping):
            raise bad_value(src, key or "<top level>", data, "must be a table")
        self.data: Mapping[str, Any] = data
        for k in data:
            if k not in self.allowed:
                listed = ", ".join(self.allowed) if self.allowed else "none"
                raise bad_value(src, self.sub(str(k)), data[k],
                                f"unknown key; allowed keys here: {listed}")

    def sub(self, name: str) -> str:
        """The dotted key of `name` inside this table."""
        return f"{self.key}.{name}" if self.key else name

    def has(self, name: str) -> bool:
        return name in self.data

    def fail(self, name: str, allowed: str) -> SceneError:
        return bad_value(self.src, self.sub(name), self.data.get(name), allowed)

    def _absent(self, name: str, default: Any, allowed: str) -> Any:
        if default is REQUIRED:
            raise SceneError(f"{self.src}: {self.sub(name)} is missing: required, {allowed}")
        return default

    def number(self, name: str, default: Any = REQUIRED, *, ge: float | None = None,
               gt: float | None = None, le: float | None = None,
               lt: float | None = None) -> Any:
        """A finite float (ints are converted) within the given bounds."""
        allowed = "must be a finite number" + _bounds(ge, gt, le, lt)
        if name not in self.data:
            return self._absent(name, default, allowed)
        value = self.data[name]
        x = _as_float(value)
        if x is None or not _in_bounds(x, ge, gt, le, lt):
            raise self.fail(name, allowed)
        return x

    def integer(self, name: str, default: Any = REQUIRED, *, ge: int | None = None,
                le: int | None = None, lt: int | None = None) -> Any:
        """An int (not a bool, not a float) within the given bounds."""
        allowed = "must be an integer" + _bounds(ge, None, le, lt)
        if name not in self.data:
            return self._absent(name, default, allowed)
        value = self.data[name]
        if (isinstance(value, bool) or not isinstance(value, int)
                or not _in_bounds(value, ge, None, le, lt)):
            raise self.fail(name, allowed)
        return value

    def string(self, name: str, default: Any = REQUIRED) -> Any:
        """A non-empty string."""
        allowed = "must be a non-empty string"
        if name not in self.data:
            return self._absent(name, default, allowed)
        value = self.data[name]
        if not isinstance(value, str) or not value.strip():
            raise self.fail(name, allowed)
        return value

    def boolean(self, name: str, default: Any = REQUIRED) -> Any:
        """true or false."""
        if name not in self.data:
            return self._absent(name, default, "must be true or false")
        value = self.data[name]
        if not isinstance(value, bool):
            raise self.fail(name, "must be true or false")
        return value

    def choice(self, name: str, enum: type[E], default: Any = REQUIRED) -> Any:
        """A member of `enum`, given by its string value."""
        values = [m.value for m in enum]  # type: ignore[var-annotated]
        allowed = "must be one of " + ", ".join(repr(v) for v in values)
        if name not in self.data:
            return self._absent(name, default, allowed)
        value = self.data[name]
        if not isinstance(value, str) or value not in values:
            raise self.fail(name, allowed)
        return enum(value)

    def floats(self, name: str, n: int, default: Any = REQUIRED, *,
               ge: float | None = None) -> Any:
        """A list of exactly `n` finite numbers, as a tuple of floats."""
        allowed = f"must be a list of {n} finite numbers" + _bounds(ge, None, None, None)
        if name not in self.data:
            return self._absent(name, default, allowed)
        value = self.data[name]
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(name, allowed)
        xs = tuple(_as_float(v) for v in value)
        if any(x is None or not _in_bounds(x, ge, None, None, None) for x in xs):
            raise self.fail(name, allowed)
        return xs

    def ints(self, name: str, n: int, *, ge: int, le: int) -> tuple[int, ...]:
        """A list of exactly `n` integers each in [ge, le] (required)."""
        allowed = f"must be a list of {n} integers, each >= {ge} and <= {le}"
        if name not in self.data:
            return self._absent(name, REQUIRED, allowed)
        value = self.data[name]
        if (not isinstance(value, list | tuple) or len(value) != n
                or any(isinstance(v, bool) or not isinstance(v, int) or not ge <= v <= le
                       for v in value)):
            raise self.fail(name, allowed)
        return tuple(value)

    def existing_file(self, name: str, base: Path) -> Path:
        """A path to an existing file (required); a relative one is taken from `base`."""
        allowed = "must be a non-empty string naming an existing file"
        value = self.string(name)
        path = base / Path(value).expanduser()
        if not path.is_file():
            raise self.fail(name, f"{allowed} (looked for {path})")
        return path

    def table(self, name: str, allowed: Iterable[str]) -> Table:
        """The sub-table `name` (empty when absent), checked for unknown keys."""
        return Table(self.src, self.sub(name), self.data.get(name, {}), allowed)

    def tables(self, name: str) -> list[Any]:
        """The array of tables `[[name]]` (empty when absent), items not yet checked."""
        value = self.data.get(name, [])
        if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
            raise self.fail(name, f"must be an array of tables, written [[{name}]]")
        return value
