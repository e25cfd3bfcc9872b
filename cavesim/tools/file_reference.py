"""The reference of cavesim's input files, written from their schemas.

Every key of a scene file and of a CAVE file: what it allows (in the words its error uses,
from `cavesim.core._schema`), its default, and what it means (the comment beside the field
in the dataclass that is its table). `cavesim schema` writes it to docs/reference.md, and a
test fails when that file no longer matches the code.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import io
import textwrap
import tokenize
from enum import Enum
from pathlib import Path
from typing import Any

from cavesim.core._schema import KeySpec, key_specs
from cavesim.core.cave.geometry import CaveFile
from cavesim.core.scene.file import FIELD_PARAMS, SceneFile
from cavesim.core.scene.model import Emitter, Field

REFERENCE_FILE = Path("docs/reference.md")  # relative to the repository root

# Where a file writes a key otherwise than its model holds it (the loader converts): what
# the file's value is, and what it means
FILE_FORMS: dict[tuple[type, str], tuple[str, str]] = {
    (Emitter, "particle_class"): ("the name of a [[particle_class]]", "what it emits"),
}
MODEL_ONLY: frozenset[tuple[type, str]] = frozenset({(Field, "times")})  # filled by the loader
KIND_PARAMS = (Field, "params")  # [field.params]: its keys depend on [field] kind

_INTRO = """\
# Reference: scene and CAVE files

Written by `cavesim schema --out docs/reference.md` from the schemas the loaders check
files against; a test fails when it no longer matches the code. Every error a file can
cause names the dotted key, the value and what is allowed, in the words of the "allowed"
column.

Keys of a table left out take their default; "required" keys must be given. TOML has no
null: a default of "not set" means the key is simply left out.
"""


def reference_text() -> str:
    """The whole reference as Markdown."""
    parts = [_INTRO,
             "## Scene files (`config/scenes/*.toml`)\n",
             *_sections(SceneFile, "", "Top level"),
             "## CAVE files (`config/cave/*.toml`)\n",
             *_sections(CaveFile, "", "Top level")]
    return "\n".join(parts)


def _sections(schema: type, key: str, title: str) -> list[str]:
    """The section of the table `schema` at `key`, then those of the tables it holds."""
    specs = [s for s in key_specs(schema, key) if (schema, s.name) not in MODEL_ONLY]
    meanings = field_comments(schema)
    rows = ["| key | allowed | default | meaning |", "|---|---|---|---|"]
    rows += [_row(schema, s, meanings.get(s.name, "")) for s in specs]
    text = [f"### {title}\n"]
    if schema.__doc__ and not schema.__doc__.startswith(f"{schema.__name__}("):
        text.append(inspect.cleandoc(schema.__doc__) + "\n")
    text.append("\n".join(rows) + "\n")
    text += [line for s in specs for line in _values(s)]
    out = ["\n".join(text)]
    for s in specs:
        sub = f"{key}.{s.name}" if key else s.name
        if (schema, s.name) == KIND_PARAMS:
            for kind, params in FIELD_PARAMS.items():
                if dataclasses.fields(params):
                    out += _sections(params, sub, f'[{sub}] with kind = "{kind.value}"')
        elif s.table is not None:
            out += _sections(s.table, sub, f"[[{sub}]]" if s.array else f"[{sub}]")
    return out


def _row(schema: type, spec: KeySpec, meaning: str) -> str:
    allowed = spec.allowed
    if (schema, spec.name) == KIND_PARAMS:
        allowed, meaning = "a table, written [field.params]", "its keys depend on kind (below)"
    allowed, meaning = FILE_FORMS.get((schema, spec.name), (allowed, meaning))
    meaning = f"not set: {meaning[len('None: '):]}" if meaning.startswith("None: ") else meaning
    cells = (f"`{spec.name}`", allowed, _default(spec), meaning)
    return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"


def _default(spec: KeySpec) -> str:
    value = spec.default
    if value is dataclasses.MISSING:
        return "required"
    if value is None:
        return "not set"
    if dataclasses.is_dataclass(value):
        return "its keys' defaults"
    if spec.table is not None or value in ((), {}):
        return "none"
    return f"`{_toml(value)}`"


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, Enum):
        return f'"{value.value}"'
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, float):
        return format(value, "g")
    return str(value)


def _values(spec: KeySpec) -> list[str]:
    """The meaning of each value of an enumerated key, where its members have comments."""
    if spec.values is None:
        return []
    meanings = field_comments(spec.values, same_line_only=True)
    named = [f'`"{m.value}"`: {meanings[m.name]}' for m in spec.values if m.name in meanings]
    return [f"`{spec.name}` values: " + "; ".join(named) + ".\n"] if named else []


def field_comments(cls: type, *, same_line_only: bool = False) -> dict[str, str]:
    """What each field (or member) of `cls` means, from the comments beside it.

    A comment on a field's own lines is its; so is an indented comment line right after
    it (a continuation). Comment lines above a field are its too, unless `same_line_only`
    (an Enum's members sit below its machinery, whose comments are not theirs).
    """
    source = textwrap.dedent(inspect.getsource(cls))
    (node,) = ast.parse(source).body
    fields = [(s.target.id if isinstance(s, ast.AnnAssign) else s.targets[0].id, s)
              for s in node.body if _is_field(s)]
    blocks = [(s.lineno, s.end_lineno) for s in node.body if not _is_field(s)]
    found: dict[str, list[str]] = {}
    for row, col, text, alone in _comments(source):
        if any(lo <= row <= hi for lo, hi in blocks):
            continue
        owner = _owner(fields, row, col, alone, same_line_only)
        if owner is not None:
            found.setdefault(owner, []).append(text)
    return {name: " ".join(texts) for name, texts in found.items()}


def _is_field(statement: ast.stmt) -> bool:
    if isinstance(statement, ast.AnnAssign):
        return isinstance(statement.target, ast.Name)
    return (isinstance(statement, ast.Assign) and len(statement.targets) == 1
            and isinstance(statement.targets[0], ast.Name))


def _owner(fields: list[tuple[str, ast.stmt]], row: int, col: int, alone: bool,
           same_line_only: bool) -> str | None:
    """Whose comment the one at (row, col) is: see `field_comments`."""
    before = [(n, s) for n, s in fields if s.lineno <= row]
    if before and before[-1][1].end_lineno >= row:
        return before[-1][0] if not alone else None  # on a field's own lines
    after = [n for n, s in fields if s.lineno > row]
    if before and (col > before[-1][1].col_offset or not after):
        return before[-1][0]  # an indented continuation, or below the last field
    if same_line_only or not after:
        return None
    return after[0]


def _comments(source: str) -> list[tuple[int, int, str, bool]]:
    """Each comment's row, column, text and whether it stands alone on its line."""
    found = []
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            row, col = token.start
            text = token.string.lstrip("#").strip()
            found.append((row, col, text, not token.line[:col].strip()))
    return found
