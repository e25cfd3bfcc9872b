"""docs/reference.md is the reference `cavesim schema` writes from the file schemas: it is
never stale, it names every key the shipped files use, and it reads the schemas' comments."""

import dataclasses
import re
import tomllib
from enum import StrEnum
from pathlib import Path

import pytest

from cavesim.tools.file_reference import (
    FILE_FORMS,
    MODEL_ONLY,
    REFERENCE_FILE,
    field_comments,
    reference_text,
)

ROOT = Path(__file__).parents[2]


def test_the_reference_in_docs_is_the_one_the_schemas_write():
    assert (ROOT / REFERENCE_FILE).read_text() == reference_text(), (
        f"{REFERENCE_FILE} is stale: run `cavesim schema --out {REFERENCE_FILE}`")


def _keys(table: dict, prefix: str = ""):
    """Every dotted key of a TOML document, arrays of tables as one key."""
    for key, value in table.items():
        dotted = f"{prefix}.{key}" if prefix else key
        items = value if isinstance(value, list) and value and isinstance(value[0], dict) \
            else [value]
        for item in items:
            if isinstance(item, dict):
                yield from _keys(item, dotted)
            else:
                yield dotted


SHIPPED = sorted([*(ROOT / "config/scenes").glob("*.toml"), *(ROOT / "config/cave").glob("*.toml")])


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_key_a_shipped_file_uses_is_in_the_reference(path):
    scene_part, cave_part = reference_text().split("## CAVE files")
    part = cave_part if path.parent.name == "cave" else scene_part
    sections = dict(re.findall(r"^### (.*?)\n(.*?)(?=^##|\Z)", part, re.S | re.M))
    for dotted in _keys(tomllib.loads(path.read_text())):
        table, _, key = dotted.rpartition(".")
        titles = [t for t in sections if re.fullmatch(
            rf"\[\[?{re.escape(table)}\]\]?( with .*)?", t)] if table else ["Top level"]
        rows = "".join(sections[t] for t in titles)
        assert f"| `{key}` |" in rows, f"{dotted} of {path.name} is not in the reference"


def test_the_file_forms_and_model_only_keys_name_real_fields():
    for schema, name in [*FILE_FORMS, *MODEL_ONLY]:
        assert name in {f.name for f in dataclasses.fields(schema)}, (schema, name)


@dataclasses.dataclass
class _Commented:
    # above a: first line
    # above a: second line
    a: int = 1  # a's own
    b: float = 2.0  # b's own;
    # b continues here, indented like a field

    def method(self) -> None:
        # inside a method: nobody's
        pass


class _Colour(StrEnum):
    """An enum's machinery comment is not its members'."""

    # a comment above the members, about the table's columns
    RED = "red"  # warm
    BLUE = "blue"


def test_comments_are_read_from_beside_and_above_each_field():
    assert field_comments(_Commented) == {
        "a": "above a: first line above a: second line a's own",
        "b": "b's own; b continues here, indented like a field"}
    assert field_comments(_Colour, same_line_only=True) == {"red".upper(): "warm"}
