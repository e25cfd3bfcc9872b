"""What a feature requires and excludes, written once, and the three things made from it.

A `Rule` is a condition on the particle pass's defines that needs another:
`Rule("HAS_TRACERS", "!HAS_DISPERSION", ...)`. Conditions are written as the C preprocessor
reads them (names, integers, `== != < <= > >=`, `! && ||`, parentheses; a name is a define
or an id of the table `ids` gives), so the same text
  - refuses a scene in one line naming its key (`check_scene`, called by the loader),
  - stops a compile of a combination no scene can make (`glsl_checks`: an `#error` block
    the assembler pastes into the particle pass),
  - and tells the shader gate which combinations exist (`holds`).
Each feature declares its rules (`Feature.rules`); the registry gathers them.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import CodeType
from typing import Any

from cavesim.core.errors import SceneError

_TOKEN = re.compile(r"\s*(?:(?P<name>[A-Z_][A-Z0-9_]*)|(?P<number>\d+)"
                    r"|(?P<operator>==|!=|<=|>=|&&|\|\||[<>!()]))")
_PYTHON = {"&&": "and", "||": "or", "!": "not"}


@dataclass(frozen=True)
class Rule:
    """`subject` needs `needs`, where `key` (a dotted scene key, `[]` where it is an array's)
    is what the scene gives: the loader's error names it and ends in `why`."""

    subject: str
    needs: str
    key: str
    why: str

    def broken(self, values: Mapping[str, int]) -> bool:
        return evaluate(self.subject, values) and not evaluate(self.needs, values)


def evaluate(condition: str, values: Mapping[str, int]) -> bool:
    """The truth of a preprocessor condition where each name has its value in `values`
    (KeyError names one it does not have)."""
    try:  # every token was read by _translated: names, numbers and operators only
        return bool(eval(_python(condition), {"__builtins__": {}}, values))  # noqa: S307
    except NameError as e:
        raise KeyError(e.name) from e


@functools.cache
def _python(condition: str) -> CodeType:
    """A condition as compiled Python."""
    return compile(_translated(condition), condition, "eval")


def _translated(condition: str) -> str:
    """A condition in Python's syntax, every token read: names, numbers and operators."""
    python = []
    position = 0
    while condition[position:].strip():
        match = _TOKEN.match(condition, position)
        if match is None or match.end() == position:
            raise ValueError(f"condition {condition!r}: cannot read from {position}")
        position = match.end()
        token = match["name"] or match["number"] or match["operator"]
        python.append(_PYTHON.get(token, token))
    return " ".join(python)


def check_scene(scene: Any, features: Iterable[Any], values: Mapping[str, int],
                source: str) -> None:
    """SceneError for the first rule of `features` (cavesim.core.features.feature.Feature)
    the scene's defines `values` break, naming its key."""
    for feature in features:
        for rule in feature.rules:
            if rule.broken(values):
                key, value = feature.where(scene, rule.key)
                what = f"{key} = {value!r} is not allowed" if value is not None else key
                raise SceneError(f"{source}: {what}: {rule.why}")


def holds(rules: Iterable[Rule], values: Mapping[str, int]) -> bool:
    """Whether a combination of defines keeps every rule (one a scene can make)."""
    return bool(eval(_table(tuple(rules)), {"__builtins__": {}}, values))  # noqa: S307


@functools.cache
def _table(rules: tuple[Rule, ...]) -> CodeType:
    """Every rule as one compiled Python condition (the shader gate asks it a million
    times)."""
    kept = [f"not (({_translated(r.subject)}) and not ({_translated(r.needs)}))"
            for r in rules]
    return compile(" and ".join(kept) or "True", "the rule table", "eval")


def glsl_checks(rules: Iterable[Rule]) -> str:
    """The `#error` block of the rules, for the particle pass."""
    lines = []
    for rule in rules:
        lines += [f"#if ({rule.subject}) && !({rule.needs})",
                  f"#error {_words(rule.subject)} needs {_words(rule.needs)}", "#endif"]
    return "\n".join(lines) + "\n"


def _words(condition: str) -> str:
    """A condition as an #error's words: the same tokens, written out."""
    return condition.replace("&&", "and").replace("||", "or").replace("!=", "is not") \
        .replace("==", "is").replace("!", "not ")
