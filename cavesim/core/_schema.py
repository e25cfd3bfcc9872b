"""TOML tables into frozen dataclasses: the one checker of cavesim's input files.

A dataclass is the schema of a table: its fields are the keys, its type hints what each value
must be, its defaults what an absent key means. Bounds and rules sit beside the field:
`rate: Annotated[float, Range(ge=0.0, le=MAX_RATE)]`. The scene loader and the CAVE loader
read their files through `Table`; where a file differs from its model (a name that becomes
an index, keys that depend on a kind) the loaders convert explicitly and pass the result to
`Table.build`. Every error names the file, the dotted key, the value and what is allowed:
`<file>: <dotted.key> = <value!r> is not allowed: <what is allowed>`, or
`<file>: <dotted.key> is missing: required, <what is allowed>`.

Types: bool; int; float (finite, an int is converted); str (non-empty); Path (an existing
file, relative to the file's folder); an Enum (by value); a tuple of n ints, n floats or n
strs; a dataclass (a table); tuple[Dataclass, ...] (an array of tables); any of them `| None`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

from cavesim.core.input_files import not_regular


@dataclass(frozen=True)
class Range:
    """Bounds of a number, or of each number of a tuple: `Range(gt=0.0, le=MAX_DIAMETER)`."""

    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None

    @classmethod
    def within(cls, bounds: tuple[float, float]) -> Range:
        """`low <= x <= high` for `bounds = (low, high)`."""
        return cls(ge=bounds[0], le=bounds[1])

    def holds(self, x: float) -> bool:
        return ((self.ge is None or x >= self.ge) and (self.gt is None or x > self.gt)
                and (self.le is None or x <= self.le) and (self.lt is None or x < self.lt))

    def __str__(self) -> str:
        """As it reads in a message, e.g. ">= 0 and <= 1e+09" (ints exactly, floats in %g)."""
        bounds = ((">=", self.ge), (">", self.gt), ("<=", self.le), ("<", self.lt))
        return " and ".join(f"{op} {b if isinstance(b, int) else format(b, 'g')}"
                            for op, b in bounds if b is not None)


@dataclass(frozen=True)
class Rule:
    """A test beyond type and range; `text` ends the message, e.g. "a power of two"."""

    text: str
    holds: Callable[[Any], bool]


@dataclass(frozen=True)
class Note:
    """What a value means, shown in its error, e.g. "[x, y, z] in metres"."""

    text: str


@dataclass(frozen=True)
class Coordinate:
    """Marks a key that holds a world position, or some of its axes ("xy", "z"): the scene's
    origin is taken from it (cavesim/core/features/origin.py), whichever table it is in."""

    axes: str = "xyz"


@dataclass(frozen=True)
class Source:
    """Where tables come from: the file errors name, the folder relative paths start from,
    and the error class to raise (SceneError, CaveError)."""

    name: str
    base: Path
    error: type[Exception]

    @classmethod
    def of(cls, path: Path | None, error: type[Exception]) -> Source:
        """The file at `path`, or "<dict>" in the working directory when there is none."""
        if path is None:
            return cls("<dict>", Path().absolute(), error)
        return cls(str(path), path.parent.absolute(), error)

    def fail(self, text: str) -> Exception:
        return self.error(f"{self.name}: {text}")


@dataclass(frozen=True)
class _Spec:
    """A field's type hint taken apart: the bare type and what is declared beside it."""

    type: Any
    range: Range | None = None
    rules: tuple[Rule | Note, ...] = ()


def _spec(hint: Any) -> _Spec:
    bounds, rules = None, []
    while True:
        if typing.get_origin(hint) is Annotated:
            for m in hint.__metadata__:
                bounds = m if isinstance(m, Range) else bounds
                rules += [m] if isinstance(m, Rule | Note) else []
            hint = hint.__origin__
        elif (typing.get_origin(hint) in (typing.Union, types.UnionType)
              and type(None) in typing.get_args(hint)):
            (hint,) = (a for a in typing.get_args(hint) if a is not type(None))
        else:
            return _Spec(hint, bounds, tuple(rules))


@functools.cache
def _hints(schema: type) -> dict[str, Any]:
    return typing.get_type_hints(schema, include_extras=True)


def _table_array(tp: Any) -> type | None:
    """X for tuple[X, ...] with X a dataclass (an array of tables), else None."""
    args = typing.get_args(tp)
    if typing.get_origin(tp) is tuple and len(args) == 2 and args[1] is Ellipsis:
        return args[0] if dataclasses.is_dataclass(args[0]) else None
    return None


def _as_float(value: object) -> float | None:
    """`value` as a finite float, or None when it is not a finite real number (bool is not)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        x = float(value)
    except OverflowError:  # an int beyond float range
        return None
    return x if math.isfinite(x) else None


def _as_int(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _as_str(value: object) -> str | None:
    return value if isinstance(value, str) and value.strip() else None


_ITEMS = {int: (_as_int, "integers"), float: (_as_float, "finite numbers"),
          str: (_as_str, "non-empty strings")}  # what a tuple may hold, and its plural


def _allowed(spec: _Spec, key: str) -> str:
    """What a value of `spec` must be, as the end of an error message."""
    tp, bounds = spec.type, f" {spec.range}" if spec.range else ""
    if tp is bool:
        text = "true or false"
    elif tp is int:
        text = "an integer" + bounds
    elif tp is float:
        text = "a finite number" + bounds
    elif tp is str:
        text = "a non-empty string"
    elif tp is Path:
        text = "a non-empty string naming an existing file"
    elif isinstance(tp, type) and issubclass(tp, Enum):
        text = "one of " + ", ".join(repr(m.value) for m in tp)
    elif dataclasses.is_dataclass(tp):
        text = f"a table, written [{key}]"
    elif _table_array(tp):
        text = f"an array of tables, written [[{key}]]"
    else:
        items = typing.get_args(tp)
        text = (f"a list of {len(items)} {_ITEMS[items[0]][1]}"
                + (f", each{bounds}" if bounds else ""))
    return "must be " + text + "".join(f", {r.text}" for r in spec.rules)


def _convert(tp: Any, value: object, base: Path) -> Any:
    """`value` as a `tp` (a scalar, a Path or a tuple of numbers), or None when it is not one."""
    if tp is bool:
        return value if isinstance(value, bool) else None
    if tp is int:
        return _as_int(value)
    if tp is float:
        return _as_float(value)
    if tp is str:
        return _as_str(value)
    if tp is Path:
        return base / Path(value).expanduser() if isinstance(value, str) and value.strip() else None
    if isinstance(tp, type) and issubclass(tp, Enum):
        return next((m for m in tp if type(m.value) is type(value) and m.value == value), None)
    items = typing.get_args(tp)
    if typing.get_origin(tp) is not tuple or len(set(items)) != 1 or items[0] not in _ITEMS:
        raise TypeError(f"the checker has no rule for the type {tp!r}")
    if not isinstance(value, list | tuple) or len(value) != len(items):
        return None
    converted = tuple(map(_ITEMS[items[0]][0], value))
    return None if None in converted else converted


def _holds(spec: _Spec, value: Any) -> bool:
    """Whether a value already of the right type keeps the field's range and rules."""
    numbers = value if isinstance(value, tuple) else (value,)
    return ((spec.range is None or all(spec.range.holds(x) for x in numbers))
            and all(r.holds(value) for r in spec.rules if isinstance(r, Rule)))


class Table:
    """One TOML table read as the dataclass `schema`; keys not among its fields are refused
    at once, naming the allowed ones."""

    def __init__(self, source: Source, key: str, data: object, schema: type) -> None:
        self.source = source
        self.key = key
        self.schema = schema
        if not isinstance(data, Mapping):
            raise self._bad(key or "<top level>", data,
                            _allowed(_Spec(schema), key) if key else "must be a table")
        self.data: Mapping[str, Any] = data
        self._fields = {f.name: f for f in dataclasses.fields(schema)}
        for k, v in data.items():
            if k not in self._fields:
                raise self._bad(self.sub(str(k)), v, "unknown key; allowed keys here: "
                                + (", ".join(self._fields) or "none"))

    def sub(self, name: str) -> str:
        """The dotted key of `name` inside this table."""
        return f"{self.key}.{name}" if self.key else name

    def has(self, name: str) -> bool:
        return name in self.data

    def bad(self, name: str, allowed: str) -> Exception:
        """The error for the value at `name`, saying what is allowed instead."""
        return self._bad(self.sub(name), self.data.get(name), allowed)

    def _bad(self, key: str, value: object, allowed: str) -> Exception:
        return self.source.fail(f"{key} = {value!r} is not allowed: {allowed}")

    def forbid(self, name: str, why: str) -> None:
        """Refuse `name` when present, e.g. a key another key's value rules out."""
        if name in self.data:
            raise self.bad(name, why)

    def get(self, name: str, hint: Any = None, *, required: bool = False,
            default: Any = dataclasses.MISSING) -> Any:
        """The checked value at `name` as its field's type (or `hint`, where the file writes
        it differently from the model). When absent: `default` (checked like a value in the
        file), else the field's default, else a "missing" error (also when `required`)."""
        spec = _spec(self._hints(name) if hint is None else hint)
        if name in self.data:
            return self._check(name, self.data[name], spec)
        if default is not dataclasses.MISSING:
            return self._check(name, default, spec)
        f = self._fields[name]
        if f.default is not dataclasses.MISSING and not required:
            return f.default
        if f.default_factory is not dataclasses.MISSING and not required:
            return f.default_factory()
        raise self.source.fail(f"{self.sub(name)} is missing: required, "
                               f"{_allowed(spec, self.sub(name))}")

    def table(self, name: str, schema: type | None = None) -> Table:
        """The sub-table `name` (empty when absent) as `schema`, by default its field's type."""
        return Table(self.source, self.sub(name), self.data.get(name, {}),
                     schema or _spec(self._hints(name)).type)

    def tables(self, name: str) -> list[Table]:
        """The array of tables `[[name]]` (empty when absent), one `Table` per item."""
        return self._items(name, self.data.get(name, []), _spec(self._hints(name)))

    def build(self, **given: Any) -> Any:
        """The `schema` object: `given` values as they are (the caller checked them), every
        other field read with `get`."""
        return self.schema(**{name: given[name] if name in given else self.get(name)
                              for name in self._fields})

    def _hints(self, name: str) -> Any:
        if name not in self._fields:
            raise KeyError(f"{self.schema.__name__} has no field {name!r}")
        return _hints(self.schema)[name]

    def _items(self, name: str, value: object, spec: _Spec) -> list[Table]:
        key = self.sub(name)
        if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
            raise self._bad(key, value, _allowed(spec, key))
        item = _table_array(spec.type)
        return [Table(self.source, f"{key}[{i}]", v, item) for i, v in enumerate(value)]

    def _check(self, name: str, value: object, spec: _Spec) -> Any:
        key = self.sub(name)
        if dataclasses.is_dataclass(spec.type):
            return Table(self.source, key, value, spec.type).build()
        if _table_array(spec.type):
            return tuple(t.build() for t in self._items(name, value, spec))
        converted = _convert(spec.type, value, self.source.base)
        if converted is None or not _holds(spec, converted):
            raise self._bad(key, value, _allowed(spec, key))
        if spec.type is Path and not converted.is_file():
            kind = not_regular(converted)  # a folder, a FIFO, a device: said, never opened
            raise self._bad(key, value, f"{_allowed(spec, key)} (looked for {converted}"
                                        + (f", which is {kind})" if kind else ")"))
        return converted


def unique_names(tables: Sequence[Table], names: Iterable[str]) -> None:
    """Refuse an item of an array of tables whose `name` an earlier item has already."""
    first: dict[str, str] = {}
    for t, name in zip(tables, names, strict=True):
        if name in first:
            raise t.bad("name", f"must be unique; {first[name]}.name has it already")
        first[name] = t.key


@dataclass(frozen=True)
class KeySpec:
    """One key of a table, as a reference describes it: the words its error would use for
    what is allowed, its default (`dataclasses.MISSING`: required), the table (or the item
    of an array of tables) it holds, and the Enum its values come from, if any."""

    name: str
    allowed: str
    default: Any
    table: type | None
    array: bool
    values: type[Enum] | None


def key_specs(schema: type, key: str = "") -> tuple[KeySpec, ...]:
    """The keys of the table `schema` at the dotted `key`, in field order."""
    specs = []
    for f in dataclasses.fields(schema):
        spec = _spec(_hints(schema)[f.name])
        item = _table_array(spec.type)
        default = (f.default_factory() if f.default_factory is not dataclasses.MISSING
                   else f.default)
        table = spec.type if dataclasses.is_dataclass(spec.type) else item
        sub = f"{key}.{f.name}" if key else f.name
        values = spec.type if isinstance(spec.type, type) and issubclass(spec.type, Enum) \
            else None
        specs.append(KeySpec(f.name, _allowed(spec, sub).removeprefix("must be "), default,
                             table, item is not None, values))
    return tuple(specs)
