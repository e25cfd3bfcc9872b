"""The TOML checker on its own (cavesim.core._schema): types, bounds and rules in messages,
unknown and missing keys, enums, tables, arrays of tables, defaults. The scene and CAVE
files are tested through it in test_scene.py and test_cave.py."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import pytest

from cavesim.core._schema import Note, Range, Rule, Source, Table, unique_names


class CheckError(ValueError):
    pass


class Colour(StrEnum):
    RED = "red"
    GREEN = "green"


def _even(n: int) -> bool:
    return n % 2 == 0


@dataclass(frozen=True)
class Leaf:
    name: str
    weight: Annotated[float, Range(gt=0.0, le=10.0)] = 1.0


@dataclass(frozen=True)
class Inner:
    depth: Annotated[int, Range(ge=0)] = 3


@dataclass(frozen=True, kw_only=True)
class Everything:
    count: Annotated[int, Range(ge=0, lt=100), Rule("an even number", _even)]
    ratio: Annotated[float, Range(ge=0.0, le=1e9)] = 0.5
    flag: bool = False
    label: str = "none"
    colour: Colour = Colour.RED
    point: Annotated[tuple[float, float, float], Note("[x, y, z] in metres")] = (0.0, 0.0, 0.0)
    size: Annotated[tuple[int, int], Range(ge=1, le=8)] = (1, 1)
    file: Path | None = None
    inner: Inner = Inner()
    extra: Inner | None = None
    leaves: tuple[Leaf, ...] = ()
    tags: dict[str, Any] = field(default_factory=dict)


def table(data: object, schema: type = Everything, key: str = "") -> Table:
    return Table(Source("f.toml", Path("/base"), CheckError), key, data, schema)


def build(data: object, schema: type = Everything, **given: Any) -> Any:
    return table(data, schema).build(**given)


def message(data: object, schema: type = Everything) -> str:
    with pytest.raises(CheckError) as info:
        build(data, schema)
    return str(info.value)


# --- values of every type ---------------------------------------------------------------


def test_a_full_table_and_the_defaults() -> None:
    built = build({"count": 4, "ratio": 2, "flag": True, "label": "x", "colour": "green",
                   "point": [1, 2.5, -3], "size": [2, 8], "inner": {"depth": 0},
                   "extra": {}, "leaves": [{"name": "a"}, {"name": "b", "weight": 10}]},
                  tags={"given": 1})
    assert built == Everything(count=4, ratio=2.0, flag=True, label="x", colour=Colour.GREEN,
                               point=(1.0, 2.5, -3.0), size=(2, 8), inner=Inner(0),
                               extra=Inner(3), leaves=(Leaf("a"), Leaf("b", 10.0)),
                               tags={"given": 1})
    assert type(built.ratio) is float and all(type(x) is float for x in built.point)
    assert build({"count": 0}) == Everything(count=0)  # every other key from its default
    assert build({"count": 0}).extra is None  # an absent optional table


@pytest.mark.parametrize(("key", "value", "allowed"), [
    ("count", "4", "must be an integer >= 0 and < 100, an even number"),
    ("count", 4.0, "must be an integer >= 0 and < 100, an even number"),
    ("count", True, "must be an integer >= 0 and < 100, an even number"),
    ("count", 100, "must be an integer >= 0 and < 100, an even number"),
    ("count", 3, "must be an integer >= 0 and < 100, an even number"),
    ("ratio", -0.5, "must be a finite number >= 0 and <= 1e+09"),
    ("ratio", float("nan"), "must be a finite number >= 0 and <= 1e+09"),
    ("ratio", float("inf"), "must be a finite number >= 0 and <= 1e+09"),
    ("ratio", 10**400, "must be a finite number >= 0 and <= 1e+09"),
    ("ratio", False, "must be a finite number >= 0 and <= 1e+09"),
    ("flag", 1, "must be true or false"),
    ("label", "", "must be a non-empty string"),
    ("label", "  ", "must be a non-empty string"),
    ("label", 5, "must be a non-empty string"),
    ("colour", "blue", "must be one of 'red', 'green'"),
    ("colour", 0, "must be one of 'red', 'green'"),
    ("point", [1, 2], "must be a list of 3 finite numbers, [x, y, z] in metres"),
    ("point", [1, True, 2], "must be a list of 3 finite numbers, [x, y, z] in metres"),
    ("point", "origin", "must be a list of 3 finite numbers, [x, y, z] in metres"),
    ("size", [0, 1], "must be a list of 2 integers, each >= 1 and <= 8"),
    ("size", [1.0, 1], "must be a list of 2 integers, each >= 1 and <= 8"),
    ("inner", 3, "must be a table, written [inner]"),
    ("leaves", {"name": "a"}, "must be an array of tables, written [[leaves]]"),
    ("leaves", [1, 2], "must be an array of tables, written [[leaves]]"),
])
def test_a_bad_value_names_key_value_and_what_is_allowed(key: str, value: object,
                                                         allowed: str) -> None:
    data = {"count": 2, key: value}
    assert message(data) == f"f.toml: {key} = {value!r} is not allowed: {allowed}"


def test_errors_inside_tables_and_arrays_have_dotted_keys() -> None:
    assert message({"count": 2, "inner": {"depth": -1}}) == (
        "f.toml: inner.depth = -1 is not allowed: must be an integer >= 0")
    assert message({"count": 2, "leaves": [{"name": "a"}, {"name": "b", "weight": 0}]}) == (
        "f.toml: leaves[1].weight = 0 is not allowed: must be a finite number > 0 and <= 10")
    nested = table({"inner": {"x": 1}}, key="outer")
    with pytest.raises(CheckError, match=re.escape("f.toml: outer.inner.x = 1 is not allowed")):
        nested.get("inner")


# --- keys -------------------------------------------------------------------------------


def test_unknown_keys_list_the_fields() -> None:
    assert message({"count": 2, "colur": "red"}) == (
        "f.toml: colur = 'red' is not allowed: unknown key; allowed keys here: count, ratio, "
        "flag, label, colour, point, size, file, inner, extra, leaves, tags")
    assert message({"count": 2, "extra": {"depht": 1}}) == (
        "f.toml: extra.depht = 1 is not allowed: unknown key; allowed keys here: depth")

    @dataclass(frozen=True)
    class Empty:
        pass

    assert message({"x": 1}, Empty).endswith("unknown key; allowed keys here: none")


def test_missing_keys_are_named_with_what_they_need() -> None:
    assert message({}) == ("f.toml: count is missing: required, must be an integer >= 0 and "
                           "< 100, an even number")
    assert message({"count": 2, "leaves": [{}]}) == (
        "f.toml: leaves[0].name is missing: required, must be a non-empty string")
    with pytest.raises(CheckError, match=r"^f\.toml: file is missing: required, must be a non-"):
        table({"count": 2}).get("file", required=True)


def test_a_top_level_that_is_not_a_table() -> None:
    assert message([1, 2]) == "f.toml: <top level> = [1, 2] is not allowed: must be a table"


# --- paths ------------------------------------------------------------------------------


def test_a_path_is_an_existing_file_relative_to_the_source(tmp_path: Path) -> None:
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "f.npz").write_bytes(b"")
    source = Source.of(tmp_path / "scene.toml", CheckError)
    assert source == Source(str(tmp_path / "scene.toml"), tmp_path, CheckError)
    t = Table(source, "", {"count": 2, "file": "data/f.npz"}, Everything)
    assert t.build().file == tmp_path / "data" / "f.npz"
    t = Table(source, "", {"count": 2, "file": "data/g.npz"}, Everything)
    with pytest.raises(CheckError) as info:
        t.build()
    assert str(info.value) == (
        f"{tmp_path / 'scene.toml'}: file = 'data/g.npz' is not allowed: must be a non-empty "
        f"string naming an existing file (looked for {tmp_path / 'data' / 'g.npz'})")


def test_a_dict_source_is_named_and_resolves_from_the_working_directory() -> None:
    source = Source.of(None, CheckError)
    assert (source.name, source.base) == ("<dict>", Path().absolute())
    assert str(source.fail("x")) == "<dict>: x"


# --- what the loaders use ---------------------------------------------------------------


def test_get_with_a_file_type_a_checked_default_and_given_fields() -> None:
    t = table({"count": 2, "label": "seven"})
    assert t.get("label", Annotated[str, Rule("a number word", str.isalpha)]) == "seven"
    assert t.get("ratio", default=3) == 3.0  # a caller's default is checked and converted
    with pytest.raises(CheckError, match=r"^f\.toml: ratio = -1 is not allowed"):
        t.get("ratio", default=-1)
    assert t.build(label="given", tags={"k": 1}).label == "given"
    with pytest.raises(KeyError, match="Everything has no field 'nope'"):
        t.get("nope")


def test_sub_tables_arrays_forbid_and_bad() -> None:
    t = table({"count": 2, "leaves": [{"name": "a"}, {"name": "a"}], "label": "x"}, key="top")
    items = t.tables("leaves")
    assert [i.key for i in items] == ["top.leaves[0]", "top.leaves[1]"]
    with pytest.raises(CheckError, match=re.escape(
            "f.toml: top.leaves[1].name = 'a' is not allowed: must be unique; top.leaves[0].name "
            "has it already")):
        unique_names(items, (i.build().name for i in items))
    assert t.table("extra").build() == Inner()  # an absent table reads as empty
    assert t.table("inner", Leaf).schema is Leaf
    assert table({}).tables("leaves") == []
    t.forbid("ratio", "never")  # absent: fine
    with pytest.raises(CheckError, match=re.escape("f.toml: top.label = 'x' is not allowed: "
                                                   "not with count = 2")):
        t.forbid("label", "not with count = 2")
    assert str(t.bad("count", "odd")) == "f.toml: top.count = 2 is not allowed: odd"


def test_range_reads_as_in_a_message() -> None:
    assert str(Range(ge=0, lt=2**63)) == ">= 0 and < 9223372036854775808"
    assert str(Range(gt=0.0, le=0.1)) == "> 0 and <= 0.1"
    assert Range.within((16, 4096)) == Range(ge=16, le=4096)
    assert Range(gt=0.0).holds(1e-300) and not Range(gt=0.0).holds(0.0)


def test_a_tuple_of_strings_keeps_its_rules() -> None:
    @dataclass(frozen=True)
    class Pair:
        names: Annotated[tuple[str, str], Rule("two different names", lambda p: p[0] != p[1])]

    assert build({"names": ["a", "b"]}, Pair) == Pair(("a", "b"))
    for bad in (["a", "a"], ["a", ""], ["a", 1], ["a"], "ab"):
        assert message({"names": bad}, Pair) == (
            f"f.toml: names = {bad!r} is not allowed: must be a list of 2 non-empty strings, "
            f"two different names")


def test_an_unsupported_type_is_a_programming_error() -> None:
    with pytest.raises(TypeError, match="no rule for the type"):
        build({"count": 2, "tags": {"a": 1}})
